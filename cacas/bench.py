"""``cacas bench``: what participants and researchers wait for, measured after warm-up (issue 6).

Every figure is a median over repeats, taken after one warm-up call:

* ``initial_train_s``: CACAA step 1, training the initial policy (:func:`train_initial_policy`);
* ``adapt_day_s``: one day's CACAS adaptation (Table III step 2) for one participant with one
  day's data (~15 interactions), called as the app calls it (:func:`adapt_policy`);
* ``decide_ms``: one robot decision, context names to action through the reshaped policy (Eq. 5,
  Eq. 4), as the tablet page does it (``dialog_state`` then ``policy.decide``);
* ``recognize_ms``: one 1-s WAV clip from file to activity (load, MFCC, CNN; Section IV-A);
* ``simulate_study_s``: 8 participants x 7 days x the paper's 4 methods, one worker process per
  core (as ``cacas simulate`` runs it);
* ``sac_updates_per_s`` / ``reference_updates_per_s``: SAC gradient updates per second of
  :class:`cacas.sac.DiscreteSAC` and of :class:`ReferenceSAC` (a plain PyTorch implementation of
  the same Eq. 1-3 with the same sizes), timed in interleaved blocks in the same run;
* ``mfcc_clips_per_s``: MFCC throughput of :func:`cacas.audio.mfcc_batch` over a batch of clips.

The machine is shared and timings are noisy: the SAC pair is interleaved so that both see the
same load, and every figure is a median.
"""

from __future__ import annotations

import copy
import math
import os
import platform
import statistics
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from cacas import spaces
from cacas.sac import SACConfig

Progress = Callable[[float, str], None]

#: The keys of the result, in table order, with their unit and the issue's target.
METRICS = (
    ("initial_train_s", "s", None),
    ("adapt_day_s", "s", ("<=", 5.0)),
    ("decide_ms", "ms", ("<=", 10.0)),
    ("recognize_ms", "ms", ("<=", 50.0)),
    ("simulate_study_s", "s", ("<=", 180.0)),
    ("sac_updates_per_s", "1/s", None),
    ("reference_updates_per_s", "1/s", None),
    ("mfcc_clips_per_s", "1/s", None),
)
#: The project's SAC must do at least this many times the reference's updates per second.
SAC_SPEEDUP_TARGET = 1.5


# --- the reference SAC -------------------------------------------------------------------------------

def _mlp(n_in: int, hidden: int, n_out: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(n_in, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                         nn.Linear(hidden, n_out))


class ReferenceSAC:
    """A plain discrete SAC, written the straightforward way, to compare the project's against.

    Two critic ``nn.Sequential`` Q_w1, Q_w2 and their target copies, an actor, ``log_alpha``, four
    Adam optimizers (one per network and one for alpha), and the same Eq. 1-3 and temperature
    update as :class:`cacas.sac.DiscreteSAC`, with the same sizes, learning rates and batch.
    """

    def __init__(self, config: SACConfig | None = None, seed: int = 0):
        c = self.config = config or SACConfig()
        torch.manual_seed(seed)
        self.generator = torch.Generator().manual_seed(seed)
        self.q1 = _mlp(c.state_dim, c.hidden, c.n_actions)
        self.q2 = _mlp(c.state_dim, c.hidden, c.n_actions)
        self.q1_target = copy.deepcopy(self.q1)
        self.q2_target = copy.deepcopy(self.q2)
        self.actor = _mlp(c.state_dim, c.hidden, c.n_actions)
        self.log_alpha = torch.tensor(math.log(c.initial_alpha), requires_grad=True)
        self.target_entropy = c.target_entropy_ratio * math.log(c.n_actions)
        self.q1_opt = torch.optim.Adam(self.q1.parameters(), lr=c.lr)
        self.q2_opt = torch.optim.Adam(self.q2.parameters(), lr=c.lr)
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=c.lr)
        self.alpha_opt = torch.optim.Adam([self.log_alpha], lr=3 * c.lr)
        self.s = torch.zeros(0, c.state_dim)
        self.a = torch.zeros(0, dtype=torch.long)
        self.r = torch.zeros(0)
        self.s2 = torch.zeros(0, c.state_dim)

    def add_batch(self, s, a, r, s2) -> None:
        self.s = torch.cat([self.s, torch.as_tensor(np.asarray(s, np.float32))])
        self.a = torch.cat([self.a, torch.as_tensor(np.asarray(a, np.int64))])
        self.r = torch.cat([self.r, torch.as_tensor(np.asarray(r, np.float32))])
        self.s2 = torch.cat([self.s2, torch.as_tensor(np.asarray(s2, np.float32))])

    def update(self, n_updates: int = 1) -> None:
        c = self.config
        for _ in range(n_updates):
            idx = torch.randint(0, len(self.a), (c.batch_size,), generator=self.generator)
            s, a, r, s2 = self.s[idx], self.a[idx], self.r[idx], self.s2[idx]
            alpha = self.log_alpha.exp().detach()
            with torch.no_grad():  # Eq. 2
                logp2 = F.log_softmax(self.actor(s2), -1)
                q2_next = torch.min(self.q1_target(s2), self.q2_target(s2))
                y = r + c.gamma * (logp2.exp() * (q2_next - alpha * logp2)).sum(-1)
            q1 = self.q1(s)  # Eq. 1, j = 1, 2
            q2 = self.q2(s)
            loss1 = F.mse_loss(q1.gather(1, a[:, None]).squeeze(1), y)
            loss2 = F.mse_loss(q2.gather(1, a[:, None]).squeeze(1), y)
            self.q1_opt.zero_grad()
            loss1.backward()
            self.q1_opt.step()
            self.q2_opt.zero_grad()
            loss2.backward()
            self.q2_opt.step()
            logp = F.log_softmax(self.actor(s), -1)  # Eq. 3
            p = logp.exp()
            q_min = torch.min(q1, q2).detach()
            actor_loss = (p * (alpha * logp - q_min)).sum(-1).mean()
            self.actor_opt.zero_grad()
            actor_loss.backward()
            self.actor_opt.step()
            entropy = -(p.detach() * logp.detach()).sum(-1).mean()  # temperature
            alpha_loss = self.log_alpha * (entropy - self.target_entropy)
            self.alpha_opt.zero_grad()
            alpha_loss.backward()
            self.alpha_opt.step()
            with torch.no_grad():  # Polyak averaging
                for net, target in ((self.q1, self.q1_target), (self.q2, self.q2_target)):
                    for p_t, p_c in zip(target.parameters(), net.parameters()):
                        p_t.mul_(1 - c.tau).add_(c.tau * p_c)


# --- measurements ------------------------------------------------------------------------------------

@dataclass
class BenchConfig:
    repeats: int = 5              # timed repeats of the short measurements (after one warm-up)
    train_repeats: int = 3        # initial policy training
    simulate_repeats: int = 1     # the whole simulated study (minutes)
    simulate_participants: int = 8
    simulate_days: int = 7
    sac_rounds: int = 7           # interleaved blocks of (project, reference)
    sac_block: int = 200          # updates per block
    mfcc_clips: int = 64
    initial_train_days: int | None = None  # None: CACAAConfig's default (the real step 1)
    short_training: bool = False  # smoke runs: 1 simulated day an adaptation (ORL makes as many updates)
    threads: int = 1

    @classmethod
    def quick(cls) -> "BenchConfig":
        """The smoke-test settings: one repeat of the long measurements (at least 3 of the short
        ones, 5 of recognize_ms), a tiny study and short training."""
        return cls(repeats=1, train_repeats=1, simulate_participants=1, simulate_days=2, sac_rounds=1,
                   sac_block=20, mfcc_clips=4, initial_train_days=1, short_training=True)

    def cacaa(self):
        """The CACAA configuration measured: the defaults, or shortened for a smoke run."""
        from cacas.adaptation import CACAAConfig

        from dataclasses import replace

        cfg = CACAAConfig()
        if self.initial_train_days is not None:
            cfg = replace(cfg, initial_train_days=self.initial_train_days)
        if self.short_training:  # ORL makes CACAS's updates (adapt_updates): shortened with it
            cfg = replace(cfg, adapt_train_days=1)
        return cfg


@dataclass
class BenchResult:
    values: dict[str, float]
    repeats: dict[str, int]
    machine: dict
    notes: list[str] = field(default_factory=list)
    #: keys measured on a smaller problem than their target's (a quick run): never "met"
    not_target_size: tuple[str, ...] = ()

    def to_json(self) -> dict:
        return {**self.values, "sac_speedup": self.sac_speedup, "repeats": self.repeats,
                "machine": self.machine, "notes": self.notes, "not_target_size": list(self.not_target_size)}

    @property
    def sac_speedup(self) -> float:
        return self.values["sac_updates_per_s"] / self.values["reference_updates_per_s"]

    def table(self) -> str:
        rows = []
        for key, unit, target in METRICS:
            v = self.values[key]
            if target is None and key == "sac_updates_per_s":
                t = f">= {SAC_SPEEDUP_TARGET}x ref: {'met' if self.sac_speedup >= SAC_SPEEDUP_TARGET else 'NOT met'}"
            elif target is None:
                t = ""
            elif key in self.not_target_size:
                t = f"{target[0]} {target[1]:g}: quick run, not the target's size"
            else:
                t = f"{target[0]} {target[1]:g}: {'met' if v <= target[1] else 'NOT met'}"
            rows.append((key, v, unit, t))
        w = max(18, *(len(t) for *_, t in rows))
        lines = [f"| {'measure':24s} | {'median':>10s} | unit | repeats | {'target':{w}s} |",
                 f"|{'-' * 26}|{'-' * 12}|------|---------|{'-' * (w + 2)}|"]
        for key, v, unit, t in rows:
            lines.append(f"| {key:24s} | {v:10.{_digits(v)}f} | {unit:4s} | {self.repeats[key]:7d} | {t:{w}s} |")
        lines.append(f"SAC speed-up over the reference: {self.sac_speedup:.2f}x (target >= {SAC_SPEEDUP_TARGET}x)")
        m = self.machine
        lines.append(f"machine: {m['cpu']}, {m['cores']} cores, torch {m['torch']} ({m['torch_threads']} thread(s)), "
                     f"Python {m['python']}, " + (f"load average {m.get('load_average_at_start')} at start, "
                                                  f"{m['load_average']} at the end (1, 5, 15 min)"
                                                  if m["load_average"] else "no load average on this system"))
        return "\n".join(lines + self.notes)


def _digits(v: float) -> int:
    return 0 if v >= 100 else 1 if v >= 10 else 2 if v >= 1 else 3


def machine_info(threads: int) -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:  # Unix's (Python's os.getloadavg: "Availability: Unix"); Windows has none, and `cacas bench` failed there
        load = [round(x, 2) for x in os.getloadavg()]
    except (OSError, AttributeError):
        load = []
    return {"cores": os.cpu_count(), "cpu": cpu, "torch": torch.__version__, "torch_threads": threads,
            "python": platform.python_version(), "platform": platform.platform(), "load_average": load}


def _median_time(fn: Callable[[], object], repeats: int, warmup: int = 1,
                 warmup_fn: Callable[[], object] | None = None) -> float:
    for _ in range(warmup):
        (warmup_fn or fn)()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def _example_people(n: int):
    from cacas.paths import study_data_dir
    from cacas.preferences import load_personas

    people = load_personas(study_data_dir() / "personas" / "example.json")
    return [people[i % len(people)] for i in range(n)] if n > len(people) else people[:n]


def one_day_of_data(initial, person, seed: int = 0):
    """A participant's first study day (~15 interactions) with the initial policy acting."""
    import pandas as pd

    from cacas import records
    from cacas.experiment import simulated_day

    rows = simulated_day(initial, person, 1, 15, np.random.default_rng(seed), 0.1, "cacas")
    return pd.DataFrame(rows, columns=records.INTERACTION_COLUMNS)


def sac_throughput(cfg: BenchConfig, progress: Progress | None = None) -> tuple[float, float]:
    """Updates per second of the project's SAC and the reference, in interleaved blocks."""
    from cacas.sac import DiscreteSAC

    rng = np.random.default_rng(0)
    n = 10_000
    idx = np.stack([rng.integers(k, size=n) for _, k in spaces.STATE_PARTS], axis=1)
    x = spaces.encode_states(idx)
    x2 = spaces.encode_states(np.roll(idx, 1, axis=0))
    a = rng.integers(spaces.N_ACTIONS, size=n)
    r = rng.choice([-1.0, 0.0, 1.0], size=n).astype(np.float32)
    ours, ref = DiscreteSAC(seed=0), ReferenceSAC(seed=0)
    for agent in (ours, ref):
        agent.buffer.add_batch(x, a, r, x2) if agent is ours else agent.add_batch(x, a, r, x2)
        agent.update(20)  # warm-up
    rates: dict[str, list[float]] = {"ours": [], "ref": []}
    for k in range(cfg.sac_rounds):
        order = (("ours", ours), ("ref", ref)) if k % 2 == 0 else (("ref", ref), ("ours", ours))
        for name, agent in order:
            t = time.perf_counter()
            agent.update(cfg.sac_block)
            rates[name].append(cfg.sac_block / (time.perf_counter() - t))
        if progress:
            progress((k + 1) / cfg.sac_rounds, f"SAC updates, round {k + 1}/{cfg.sac_rounds}")
    return statistics.median(rates["ours"]), statistics.median(rates["ref"])


def _recognizer(notes: list[str]):
    from cacas.audio import SoundCNN, SoundRecognizer
    from cacas.audio.model import default_model_path

    if default_model_path().exists():
        return SoundRecognizer.load()
    notes.append("note: no trained sound model in study_data/models; recognize_ms timed with an untrained "
                 "SoundCNN of the same architecture (the same computation)")
    torch.manual_seed(0)
    return SoundRecognizer(SoundCNN())


def _test_signal(seconds: float = 1.0, seed: int = 0) -> np.ndarray:
    from cacas.audio import SAMPLE_RATE

    rng = np.random.default_rng(seed)
    t = np.arange(int(SAMPLE_RATE * seconds)) / SAMPLE_RATE
    return (0.3 * np.sin(2 * np.pi * 440 * t) + 0.05 * rng.standard_normal(len(t))).astype(np.float32)


def run_bench(cfg: BenchConfig | None = None, progress: Progress | None = None) -> BenchResult:
    """Run every measurement; ``progress(fraction, message)`` is told as each one starts."""
    cfg = cfg or BenchConfig()
    load_at_start = machine_info(cfg.threads)["load_average"]
    torch.set_num_threads(cfg.threads)
    say = progress or (lambda f, m: None)
    notes: list[str] = []
    values: dict[str, float] = {}
    repeats: dict[str, int] = {}

    from cacas.adaptation import CACAAConfig, adapt_policy, load_initial_policy, train_initial_policy
    from cacas.d4a import load_d4a
    from cacas.experiment import PAPER_METHODS, simulate_study
    from cacas.parallel import default_jobs
    from cacas.simulator import dialog_state

    d4a = load_d4a()
    cacaa = cfg.cacaa()
    if cfg.short_training:
        notes.append(f"note: QUICK run (smoke test): adaptations train {cacaa.adapt_train_days} simulated day(s), "
                     f"{cacaa.adapt_updates} SAC updates (ORL as many); these figures are not the benchmark")
    initial = load_initial_policy()
    person = _example_people(1)[0]

    say(0.0, "SAC updates: project and reference, interleaved")
    ours, ref = sac_throughput(cfg, lambda f, m: say(0.15 * f, m))
    values["sac_updates_per_s"], values["reference_updates_per_s"] = ours, ref
    repeats["sac_updates_per_s"] = repeats["reference_updates_per_s"] = cfg.sac_rounds

    say(0.15, "one robot decision")
    data = one_day_of_data(initial, person)
    adapted = adapt_policy(initial, data, "cacas", seed=1, d4a=d4a, config=cacaa).policy
    contexts = [(spaces.ACTIVITIES[i % spaces.N_ACTIVITIES], spaces.SCENES[i % spaces.N_SCENES], (2 * i) % 24,
                 spaces.INTERVAL_BINS[i % len(spaces.INTERVAL_BINS)]) for i in range(50)]
    previous = {"type": "type_1", "robot_action": "remind to turn off", "response": "accept", "user_action": ""}

    def decide_all():
        for act, scene, hour, interval in contexts:
            adapted.decide(dialog_state(act, scene, hour, interval, previous))

    values["decide_ms"] = _median_time(decide_all, max(cfg.repeats, 3)) * 1000 / len(contexts)
    repeats["decide_ms"] = max(cfg.repeats, 3) * len(contexts)

    say(0.2, "one 1-s clip recognised from file")
    import soundfile as sf

    from cacas.audio import SAMPLE_RATE, mfcc_batch

    rec = _recognizer(notes)
    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "one_second.wav"
        sf.write(wav, _test_signal(), SAMPLE_RATE, subtype="PCM_16")
        n_rec = max(cfg.repeats * 4, 5)
        values["recognize_ms"] = _median_time(lambda: rec.recognize(wav), n_rec, warmup=3) * 1000
        repeats["recognize_ms"] = n_rec

    say(0.25, "MFCC of a batch of clips")
    clips = [_test_signal(seed=k) for k in range(cfg.mfcc_clips)]
    values["mfcc_clips_per_s"] = cfg.mfcc_clips / _median_time(lambda: mfcc_batch(clips), max(cfg.repeats, 3))
    repeats["mfcc_clips_per_s"] = max(cfg.repeats, 3)

    say(0.3, "one day's CACAS adaptation")
    values["adapt_day_s"] = _median_time(lambda: adapt_policy(initial, data, "cacas", seed=1, d4a=d4a,
                                                              config=cacaa), cfg.repeats)
    repeats["adapt_day_s"] = cfg.repeats

    say(0.4, "training the initial policy (CACAA step 1)")
    if cfg.initial_train_days is not None:
        notes.append(f"note: initial_train_s with {cfg.initial_train_days} simulated day(s) of step 1, not "
                     f"the default {CACAAConfig().initial_train_days} (quick run)")
    one_day = CACAAConfig(initial_train_days=1)  # warm-up: one simulated day of step 1
    values["initial_train_s"] = _median_time(lambda: train_initial_policy(d4a, cacaa), cfg.train_repeats,
                                             warmup_fn=lambda: train_initial_policy(d4a, one_day))
    repeats["initial_train_s"] = cfg.train_repeats

    say(0.65, f"simulated study: {cfg.simulate_participants} participants x {cfg.simulate_days} days x "
              f"{len(PAPER_METHODS)} methods")
    people = _example_people(cfg.simulate_participants)
    if (cfg.simulate_participants, cfg.simulate_days) != (8, 7):
        notes.append(f"note: simulate_study_s for {cfg.simulate_participants} participant(s) x "
                     f"{cfg.simulate_days} day(s), not 8 x 7 (quick run)")

    def study():  # as `cacas simulate` runs it: one worker process per core (the library's default is 1)
        simulate_study(people, days=cfg.simulate_days, methods=PAPER_METHODS, seed=0, d4a=d4a,
                       initial_policy=initial, config=None if cacaa == CACAAConfig() else cacaa,
                       jobs=default_jobs())

    not_target_size = []
    if cfg.short_training:  # adaptations shortened: not the adaptation the target is about
        not_target_size.append("adapt_day_s")
    if (cfg.simulate_participants, cfg.simulate_days) != (8, 7) or cfg.short_training:
        not_target_size.append("simulate_study_s")
    values["simulate_study_s"] = _median_time(study, cfg.simulate_repeats, warmup=0)
    repeats["simulate_study_s"] = cfg.simulate_repeats
    say(1.0, "done")
    notes.append("timings on a shared machine are noisy; the SAC pair ran in interleaved blocks in the same run")
    machine = machine_info(cfg.threads)
    machine["load_average_at_start"] = load_at_start
    return BenchResult({k: float(values[k]) for k, _, _ in METRICS}, repeats, machine, notes,
                       tuple(not_target_size))

"""CACAA, the Context-Aware Conversation Adaptation Algorithm (Table III), and the baselines.

Step 1 trains the initial policy pi_theta with discrete SAC against the generic user simulator
(the generic preference ``up``: the D4A pairs). Step 2, after each study day, adapts it from the
user data D alone: UMA (Table II) builds D and the user model f_mu, MLP_policy learns from D's
"accept" data, and SAC trains against the Decision Model on states generated from D, with the
reshaped policy (Eq. 5) acting. The participant's described preferences are never read here.

Methods (Fig. 4; every method adapts from the same day-by-day interactions):
* ``cacas``: the above, deployed as Eq. 5 with beta = 0.7;
* ``cacas-no-pr``: the same without policy reshaping (pi_theta acts and is deployed);
* ``orl``: the original SAC adapted with the user data: the agent of step 1 goes on learning as
  online SAC does, from its replay memory (what its buffer holds when step 1 ends: the last round
  of simulated days, as Table III empties the buffer every training day; kept with the initial policy)
  with the recorded transitions added, with as many gradient updates after each day as CACAS's
  SAC makes (``adapt_updates``); no user model, no simulator. The recorded transitions among
  the 1,144 remembered from the generic simulator (with the default settings) are our reading of
  the paper's "forgetting user feedback data" (Section IV-C.2);
* ``nn``: MLP_policy alone;
* ``bandit``: a contextual Thompson-sampling bandit (not in the paper);
* ``sac-user-data`` (not in the paper): SAC from the policy in force, its memory emptied, learning
  from the recorded transitions alone with ``user_data_updates_per_transition`` updates per new
  one (1, SAC's usual update-to-data ratio). Our first reading of ORL; kept because it shows what
  plain RL on the user data alone reaches with consistent simulated participants.

Deviation from Table III, stated: Table III writes a_t = argmax pi(s_t) while training; SAC learns
the value of actions it tries, so during training we *sample* a_t ~ pi(s_t) (SAC's own
exploration) and use the argmax (Eq. 4) when the robot acts with people and for evaluation.
``CACAAConfig(adapt_actions="argmax")`` trains step 2 as printed; measured on seven persona sets
(docs/results.md), it ends below sampling on every one.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd
import torch

from cacas import records, spaces
from cacas.d4a import D4A, load_d4a
from cacas.errors import CacasError, check_fields, each, number_where, share_rule, whole_from
from cacas.paths import study_data_dir
from cacas.policy import BanditPolicy, MLPPolicy, ReshapedPolicy, accept_pairs, policy_from_bytes
from cacas.preferences import Participant
from cacas.sac import DiscreteSAC, SACConfig
from cacas.simulator import ContextSource, ResponseModel, StateGenerator, preference_states, steps_per_day
from cacas.user_model import UMA, DecisionModel

Progress = Callable[[float, str], None]
METHODS = records.METHOD_ORDER
INITIAL_POLICY_FILE = "initial_policy.pt"


#: Step 2's ways of choosing the action to train on (:attr:`CACAAConfig.adapt_actions`).
ADAPT_ACTIONS = ("sample", "argmax")


def greedy(probabilities: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
    """A behaviour that always takes ``probabilities``' most likely action (Table III: "a_t =
    arg max_{a in A}(pi(s_t))"), as one-hot rows; ties go to the first action, as Eq. 4's argmax."""
    def behaviour(x: np.ndarray) -> np.ndarray:
        p = probabilities(x)
        out = np.zeros_like(p)
        out[np.arange(len(p)), p.argmax(1)] = 1.0
        return out
    return behaviour


#: The longest step of the simulated day (:attr:`CACAAConfig.k_minutes`): two steps a day, one transition.
K_MINUTES_MAX = 720


@dataclass
class CACAAConfig:
    """Hyper-parameters of Table III (names after the paper where it names them)."""

    k_minutes: float = 10.0          # generate_state every K minutes: 144 steps a simulated day
    parallel_days: int = 8           # simulated days stepped side by side (batched environment)
    initial_train_days: int = 30     # step 1
    adapt_train_days: int = 2        # step 2, after each study day
    updates_per_step: int = 1
    threshold: float = 0.7           # DM: probability threshold of the user model
    beta: float = 0.7                # Eq. 5 importance weight
    recorded_share: float = 0.8      # generate_state(t, h, D): share of steps with a recorded activity
    user_data_updates_per_transition: int = 1  # sac-user-data: update-to-data ratio on real transitions
    user_model_interval: int = 1     # Table II's N: f_mu (and MLP_policy) retrained when idx % N == 0
    # step 2's actions while training: "sample" a_t ~ pi(s_t) (SAC's exploration; the default) or
    # "argmax", Table III as printed (docs/results.md measures both: argmax is below on every set)
    adapt_actions: str = "sample"
    sac: SACConfig = field(default_factory=SACConfig)

    def __post_init__(self) -> None:
        """Every field checked (also by ``dataclasses.replace``): each wrong one named with its value
        and what is valid, all in one CacasError (k_minutes 0 divided by zero deep in training,
        parallel_days 0 failed on an empty batch, beta 1.5 weighed the MLP policy by -0.5 in Eq. 5)."""
        each(lambda: check_fields(self, CACAA_RULES),
             lambda: isinstance(self.sac, SACConfig) and check_fields(self.sac, TABLE_I_SAC, prefix="sac."))

    def to_dict(self) -> dict:
        return asdict(self)

    @property
    def adapt_updates(self) -> int:
        """SAC gradient updates of one adaptation (step 2), as :func:`run_sac_training` makes
        them: a round of simulated days has one transition (s, a, r, s') fewer than it has steps
        (the day's last state has no next one), and each transition is followed by
        ``updates_per_step`` updates."""
        return self.adapt_train_days * (steps_per_day(self.k_minutes) - 1) * self.updates_per_step

    def trains_initial_policy_like(self, other: "CACAAConfig") -> bool:
        """Whether step 1 (:func:`train_initial_policy`) trains the same with both configs."""
        return all(getattr(self, f) == getattr(other, f) for f in STEP1_FIELDS)


#: What each :class:`CACAAConfig` field takes (:func:`cacas.errors.check_fields`); ``sac`` is a
#: :class:`SACConfig` (which checks its own fields) sized for Table I (:data:`TABLE_I_SAC`).
CACAA_RULES = {
    # 0 divided by zero in steps_per_day; above 720 a simulated day had one step and no transition to learn from
    "k_minutes": number_where(lambda v: 0 < v <= K_MINUTES_MAX, f"a number of minutes above 0 and at most "
                                                                 f"{K_MINUTES_MAX} (a simulated day has at least "
                                                                 "two steps)"),
    "parallel_days": whole_from(1, "simulated days stepped side by side"),
    "initial_train_days": whole_from(0, "rounds of simulated days of step 1; 0: the untrained networks"),
    "adapt_train_days": whole_from(0, "rounds of simulated days of step 2; 0: no SAC training"),
    "updates_per_step": whole_from(0, "SAC updates after each simulated step; 0: none"),
    "threshold": share_rule("DM: the user model answers where its probability is above it, the generic user elsewhere"),
    "beta": share_rule("Eq. 5's weight of the SAC policy; the MLP policy's is 1 - beta"),
    "recorded_share": share_rule("share of step 2's simulated steps with an activity recorded in D"),
    "user_data_updates_per_transition": whole_from(0, "sac-user-data's SAC updates per new recorded "
                                                      "transition; 0: none"),
    "user_model_interval": whole_from(1, "Table II's N: f_mu retrained every N interactions"),
    "adapt_actions": ((lambda v: v in ADAPT_ACTIONS), ", ".join(ADAPT_ACTIONS)),
    "sac": ((lambda v: isinstance(v, SACConfig)), "a cacas.sac.SACConfig"),
}

#: What CACAA's SAC must be sized for (its other fields: :data:`cacas.sac.SAC_RULES`).
TABLE_I_SAC = {
    "state_dim": ((lambda v: v == spaces.STATE_DIM), f"{spaces.STATE_DIM} (Table I's one-hot state, which CACAA "
                                                      "acts on)"),
    "n_actions": ((lambda v: v == spaces.N_ACTIONS), f"{spaces.N_ACTIONS} (Table I's actions)"),
}


#: The fields of :class:`CACAAConfig` that CACAA step 1 reads (the others are step 2's).
STEP1_FIELDS = ("k_minutes", "parallel_days", "initial_train_days", "updates_per_step", "sac")


@dataclass
class AdaptationResult:
    policy: object
    log: list[str]
    parameters: dict
    duration_s: float


def _threads() -> None:
    # Small networks and batches: extra intra-op threads only add synchronisation overhead.
    if torch.get_num_threads() > 1:
        torch.set_num_threads(1)


def run_sac_training(sac: DiscreteSAC, behaviour: Callable[[np.ndarray], np.ndarray], responder,
                     source: ContextSource, days: int, cfg: CACAAConfig, rng: np.random.Generator,
                     progress: Progress | None = None, label: str = "training") -> dict:
    """The inner loops of Table III: simulated days of generate_state -> act -> respond ->
    store (s, a, r, s') -> SAC update (Eq. 1, 3), the replay buffer emptied at the start of every
    round (Table III's "buffer b = ∅" each training day), so it ends holding the last round's
    transitions. ``behaviour(x)`` gives action probabilities
    for one-hot states x; ``responder.respond(states, actions)`` the responses."""
    gen = StateGenerator(source, cfg.parallel_days, cfg.k_minutes, rng)
    rewards = np.array([spaces.REWARDS[r] for r in spaces.RESPONSES])
    total = days * gen.steps_per_day
    info: dict = {}
    accepted = n = updates = 0
    for day in range(days):
        sac.buffer.clear()  # Table III: "h = ∅; buffer b = ∅" at the start of every training day
        gen.reset()
        s = gen.generate_state()
        x = spaces.encode_states(s)
        while True:
            p = behaviour(x)
            cdf = np.cumsum(p, axis=1)
            a = np.minimum((cdf < rng.random((len(p), 1)) * cdf[:, -1:]).sum(1), spaces.N_ACTIONS - 1)
            ur = responder.respond(s, a)
            gen.observe(a, ur)
            accepted += int((ur == spaces.ACCEPT).sum())
            n += len(ur)
            if gen.done:
                break
            s2 = gen.generate_state()
            x2 = spaces.encode_states(s2)
            sac.buffer.add_batch(x, a, rewards[ur], x2)
            info = sac.update(cfg.updates_per_step)
            updates += cfg.updates_per_step
            s, x = s2, x2
        if progress:
            progress((day + 1) / days, f"{label}: round {day + 1}/{days} of {cfg.parallel_days} simulated days "
                                       f"side by side against the simulated user (it accepted "
                                       f"{accepted / max(n, 1):.0%} of the robot's actions)")
    info["accept_rate"] = accepted / max(n, 1)
    info["steps"] = total
    info["updates"] = updates
    return info


def train_initial_policy(d4a: D4A | None = None, config: CACAAConfig | None = None, seed: int = 0,
                         progress: Progress | None = None) -> ReshapedPolicy:
    """CACAA step 1: pi_theta trained against the generic user simulator (D4A pairs)."""
    _threads()
    cfg = config or CACAAConfig()
    d4a = d4a or load_d4a()
    rng = np.random.default_rng(seed)
    sac = DiscreteSAC(cfg.sac, seed=seed)
    run_sac_training(sac, sac.action_probabilities, ResponseModel(d4a.table), ContextSource.generic(),
                     cfg.initial_train_days, cfg, rng, progress, "initial policy")
    # the original SAC's experience, which ORL goes on learning from: what Table III's buffer holds
    # when step 1 ends (its last round, emptied at the start of each)
    sac.memory = sac.replay_memory()
    return ReshapedPolicy(sac, None, beta=1.0, method="initial")


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:12]


def initial_policy_path(d4a: D4A | None = None, config: CACAAConfig | None = None) -> Path:
    """Where the initial policy trained against ``d4a`` with ``config`` is kept: the shipped D4A
    pairs' (or ``None``) with the default step-1 settings at ``study_data/models/initial_policy.pt``;
    another table's beside it, named by a digest of its pairs (``initial_policy-d4a-<digest>.pt``),
    and step-1 settings of a config that trains otherwise (:data:`STEP1_FIELDS`) add a digest of
    them (``-config-<digest>``), so that each trains its own once and none reuses another's."""
    folder = study_data_dir() / "models"
    name = INITIAL_POLICY_FILE
    if d4a is not None:
        digest = _digest(np.ascontiguousarray(d4a.table, dtype=np.int8).tobytes())
        if digest != _digest(np.ascontiguousarray(load_d4a().table, dtype=np.int8).tobytes()):
            name = f"initial_policy-d4a-{digest}.pt"
    if config is not None and not config.trains_initial_policy_like(CACAAConfig()):
        settings = repr({f: asdict(config)[f] for f in STEP1_FIELDS}).encode()
        name = name.removesuffix(".pt") + f"-config-{_digest(settings)}.pt"
    return folder / name


def load_initial_policy(progress: Progress | None = None, path: str | Path | None = None,
                        d4a: D4A | None = None, config: CACAAConfig | None = None) -> ReshapedPolicy:
    """The initial policy (CACAA step 1) trained against ``d4a`` (default: the shipped D4A pairs)
    with ``config``'s step-1 settings (default: :class:`CACAAConfig`'s), from
    :func:`initial_policy_path`; trained (about half a minute with the defaults) and saved
    atomically on first use if the file is missing. A researcher's own D4A table, or a config
    that trains step 1 otherwise, gets an initial policy of its own. A damaged file (not a policy
    any more) is moved aside as ``<name>.damaged-<ns>`` and the policy trained again: it is made
    from the D4A pairs alone, the same on this machine (the tablet said to put another version in
    force, which before day 1 there is not)."""
    path = Path(path) if path else initial_policy_path(d4a, config)
    if path.exists():
        try:
            return policy_from_bytes(path.read_bytes())
        except CacasError:
            try:
                path.replace(path.with_name(f"{path.name}.damaged-{time.time_ns()}"))
            except FileNotFoundError:  # another process moved it aside first
                pass
    policy = train_initial_policy(d4a=d4a, config=config, progress=progress)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + f".{time.time_ns()}.tmp")
    tmp.write_bytes(policy.to_bytes())
    tmp.replace(path)
    return policy


def orl_transitions(interactions: pd.DataFrame) -> tuple[np.ndarray, ...]:
    """The recorded data points (:func:`cacas.records.is_recorded`, the data every method adapts
    from) as SAC transitions (s, a, r, s'): a robot action answered with
    accept / reject; for a user-initiated one the request (+1) and the robot's own action (-1):
    "do nothing" when it stayed quiet (Section V-B), the proposal the participant answered with
    a request instead otherwise (none when the request is that proposal, which the tablet records
    as an accept but the library API takes as it is: D holds it as accepted only). s' is the
    next interaction's state of the day (or s itself at the end of a day). Returns
    (s, a, r, s', day) arrays."""
    empty = (np.zeros((0, spaces.STATE_DIM), np.float32), np.zeros(0, np.int64), np.zeros(0, np.float32),
             np.zeros((0, spaces.STATE_DIM), np.float32), np.zeros(0, np.int64))
    if len(interactions) == 0:
        return empty
    df = interactions.sort_values(["day", "index"], kind="stable").reset_index(drop=True)
    x = spaces.encode_states(records.policy_states(df))
    nxt = np.arange(len(df)) + 1
    same_day = np.append(df["day"].to_numpy()[1:] == df["day"].to_numpy()[:-1], False)
    nxt = np.where(same_day, nxt, np.arange(len(df)))
    s, a, r, s2, days = [], [], [], [], []
    recorded = records.is_recorded(df).to_numpy()  # the data every method adapts from
    for i, row in df.iterrows():
        if not recorded[i]:
            continue
        if row["type"] == records.USER_INITIATED:
            asked, robot = spaces.action_index(row["user_action"]), spaces.action_index(row["robot_action"])
            # the robot's own action is rejected, unless it is what was asked for (as in D: Table II)
            pairs = [(asked, 1.0)] + ([(robot, -1.0)] if robot != asked else [])
        else:
            pairs = [(spaces.action_index(row["robot_action"]), spaces.REWARDS[row["response"]])]
        for act, rew in pairs:
            s.append(x[i]); a.append(act); r.append(rew); s2.append(x[nxt[i]]); days.append(row["day"])  # noqa: E702
    if not s:
        return empty
    return np.array(s), np.array(a), np.array(r, np.float32), np.array(s2), np.array(days)


def adapt_policy(previous, interactions: pd.DataFrame, method: str = "cacas", seed: int = 0,
                 progress: Progress | None = None, config: CACAAConfig | None = None,
                 d4a: D4A | None = None) -> AdaptationResult:
    """CACAA step 2 (or a baseline) from ALL of one participant's interactions so far.

    ``previous``: the policy in force (its SAC part is trained further); ``interactions``:
    INTERACTION_COLUMNS rows of days 1..d. Never reads described preferences.
    """
    if method not in METHODS:
        raise CacasError(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    _threads()
    cfg = config or CACAAConfig()
    d4a = d4a or load_d4a()
    t0 = time.perf_counter()
    log: list[str] = []
    rng = np.random.default_rng(seed)
    say = (lambda f, m: (log.append(m), progress and progress(f, m)))  # noqa: E731
    n_rows = len(interactions)
    params = {"method": method, "interactions": n_rows, "seed": seed}

    if method == "nn":
        states, actions = accept_pairs(interactions)
        if not len(actions):  # nothing to learn from: an untrained network, its actions drawn by its seed,
            # took over (helper's bug hunt: a participant who wants quiet fell from 0.72 to 0.00); the robot keeps
            # the policy in force, as CACAS leaves its MLP part out until there is accepted data
            say(1.0, "no accepted action yet: nothing to train the MLP policy on; the policy in force is kept")
            kept = previous if previous is not None else load_initial_policy(d4a=d4a, config=config)
            return AdaptationResult(kept, log, params, time.perf_counter() - t0)
        mlp = MLPPolicy(seed=seed).fit(states, actions)
        say(1.0, f"MLP policy trained on {len(actions)} accepted actions")
        return AdaptationResult(ReshapedPolicy(None, mlp, 0.0, method), log, params, time.perf_counter() - t0)
    if method == "bandit":
        policy = BanditPolicy(d4a.table, seed=seed).fit(interactions)
        say(1.0, f"bandit posteriors updated from {n_rows} interactions")
        return AdaptationResult(policy, log, params, time.perf_counter() - t0)

    base_sac = previous.sac if isinstance(previous, ReshapedPolicy) and previous.sac is not None else None
    if base_sac is None:
        base_sac = load_initial_policy(d4a=d4a, config=config).sac
    # SAC's settings (gamma, the target entropy, ...) are the previous agent's unless a config is given
    sac = base_sac.copy(seed=seed, keep_memory=method == "orl", config=config.sac if config else None)

    if method in ("orl", "sac-user-data"):
        s, a, r, s2, day = orl_transitions(interactions)
        # new: the transitions of the day just lived (the latest day of the interactions), none if
        # that day recorded nothing (counting those of the latest day with some made sac-user-data
        # learn again from an earlier day's after a day the participant answered nothing)
        latest = int(interactions["day"].max()) if len(interactions) else None
        n_new = int((day == latest).sum()) if len(day) else 0
        if method == "orl":
            if sac.memory is None:
                sac.memory = load_initial_policy(d4a=d4a, config=config).sac.memory
            if sac.memory is None:
                raise CacasError("ORL needs the initial policy's replay memory, and the initial policy file "
                                 f"has none; valid: a file written by this version ({initial_policy_path(d4a, config)})")
            sac.restore_memory(sac.memory)
            updates = cfg.adapt_updates
            params["remembered"] = int(len(sac.memory["a"]))
        else:
            updates = cfg.user_data_updates_per_transition * n_new
        if len(a):
            sac.buffer.add_batch(s, a, r, s2)
            sac.update(updates)
        say(1.0, f"SAC: {updates} updates from {sac.buffer.size} transitions in its replay buffer, "
                 f"{len(a)} of them recorded ({n_new} new)")
        params["updates"] = updates
        return AdaptationResult(ReshapedPolicy(sac, None, 1.0, method), log, params, time.perf_counter() - t0)

    # cacas / cacas-no-pr: UMA (Table II) -> f_mu; MLP_policy; SAC against DM on states from D.
    uma = UMA.replay(interactions, cfg.user_model_interval, seed=seed)
    data, user_model = uma.data, uma.model
    stale = (f", as retrained after interaction {uma.fitted_interactions} of {len(interactions)} "
             f"(N = {cfg.user_model_interval})") if uma.fitted_interactions < len(interactions) else ""
    say(0.05, f"user model trained on {user_model.trained_on} samples{stale}; D holds {len(data)} "
              f"(D_f {len(data.subset('D_f'))}, D_i {len(data.subset('D_i'))}, D_g {len(data.subset('D_g'))})")
    mlp = None
    if method == "cacas":  # Table III: "If f_mu is new, MLP_policy <- MLP_policy(D)", on the same D
        states, actions = accept_pairs(uma.fitted_rows(interactions))
        mlp = MLPPolicy(seed=seed).fit(states, actions) if len(actions) else None
        say(0.1, f"MLP policy trained on {len(actions)} accepted actions")
    policy = ReshapedPolicy(sac, mlp, cfg.beta, method)
    dm = DecisionModel(user_model, ResponseModel(d4a.table), cfg.threshold, data.support(), data.answered_pairs())
    source = ContextSource.from_user_data(data.contexts(), cfg.recorded_share)
    behaviour = greedy(policy.action_probabilities) if cfg.adapt_actions == "argmax" else policy.action_probabilities
    info = run_sac_training(sac, behaviour, dm, source, cfg.adapt_train_days, cfg, rng,
                            (lambda f, m: say(0.1 + 0.9 * f, m)), "adaptation")
    params.update(beta=policy.beta, threshold=cfg.threshold, train_days=cfg.adapt_train_days,
                  adapt_actions=cfg.adapt_actions,
                  k_minutes=cfg.k_minutes, parallel_days=cfg.parallel_days,
                  target_entropy_ratio=sac.config.target_entropy_ratio, gamma=sac.config.gamma)
    say(1.0, f"SAC adapted: {cfg.adapt_train_days} rounds of {cfg.parallel_days} simulated days side by side "
             f"({info['steps']} steps of {cfg.k_minutes:g} minutes, {info['updates']} updates), "
             f"entropy {info.get('entropy', float('nan')):.2f}, alpha {info.get('alpha', float('nan')):.3f}")
    return AdaptationResult(policy, log, params, time.perf_counter() - t0)


#: The seed of a human study's Fig. 4 test states (:func:`fig4_metrics`): one test set per
#: participant, whatever seed an adaptation ran with, so that every version and method of a
#: participant is scored on the same states.
EVALUATION_SEED = 0


def evaluation_states(participant: Participant, n: int = 400, seed: int = 0) -> np.ndarray:
    """Fig. 4's test states (n, 7) from the described preferences: covered S1-S5 contexts (the
    robot idle, S5 "do nothing", unless a preference names the tasks it applies during), and a
    random previous action and response (S6, S7)."""
    rng = np.random.default_rng(seed)
    ctx = preference_states(participant, n, rng)
    return np.concatenate([ctx, rng.integers(spaces.N_ACTIONS, size=(n, 1)),
                           rng.integers(spaces.N_RESPONSES, size=(n, 1))], axis=1)


def preference_accuracy(policy, participant: Participant, n: int = 400, seed: int = 0,
                        states: np.ndarray | None = None) -> float:
    """Fig. 4: on states generated from the described preferences, the share where the
    policy's chosen action (Eq. 4) is the preferred one (given ``states`` that no preference
    covers are not counted; NaN if none is covered). Evaluation only."""
    states = evaluation_states(participant, n, seed) if states is None else states
    table = participant.preferred_action_table()
    preferred = table[states[:, 0], states[:, 1], states[:, 2], states[:, 3], states[:, 4]]
    covered = preferred >= 0
    if not covered.any():
        return float("nan")
    return float((policy.greedy(states[covered]) == preferred[covered]).mean())


def accuracy_by_preference(policy, participant: Participant, states: np.ndarray) -> pd.DataFrame:
    """Fig. 4's accuracy broken down by described preference: which preferences a policy has
    learnt. One row per preference: preference (1-based), label, activity, action, states (the
    test states it covers), correct (of those, where the policy's Eq. 4 action is the preferred
    one), accuracy. Evaluation only."""
    chosen = policy.greedy(states)
    rows = []
    for k, pref in enumerate(participant.preferences, start=1):
        covered = np.ones(len(states), bool)
        for col, allowed in enumerate([pref.activity_indices(), pref.scene_indices(), pref.slot_indices(),
                                       pref.interval_indices(), pref.task_indices()]):
            covered &= np.isin(states[:, col], allowed)
        correct = int((chosen[covered] == pref.action_index).sum())
        n = int(covered.sum())
        rows.append({"preference": k, "label": pref.label(), "activity": "/".join(pref.activity),
                     "action": pref.action, "states": n,
                     "correct": correct, "accuracy": correct / n if n else float("nan")})
    return pd.DataFrame(rows)


def fig4_metrics(policy, participant: Participant, seed: int = 0, n: int = 400) -> dict:
    """Fig. 4's metrics of a policy as an adaptation run records them (JSON-able): on the
    ``n`` test states of :func:`evaluation_states`, ``preference_accuracy`` and ``by_preference``,
    one entry per described preference (preference, label, activity, action, states, correct; see
    :func:`accuracy_by_preference`). Evaluation only."""
    states = evaluation_states(participant, n, seed)
    table = accuracy_by_preference(policy, participant, states).drop(columns="accuracy")
    return {"preference_accuracy": preference_accuracy(policy, participant, states=states),
            "by_preference": table.to_dict("records")}


def preferences_learnt(before, after, participant: Participant, n: int = 400, seed: int = 0) -> pd.DataFrame:
    """Each described preference, how often two policies choose its action on the same Fig. 4
    test states: preference, label, action, states, before, after (accuracies). Evaluation only."""
    states = evaluation_states(participant, n, seed)
    out = accuracy_by_preference(before, participant, states).rename(columns={"accuracy": "before"})
    out["after"] = accuracy_by_preference(after, participant, states)["accuracy"]
    return out[["preference", "label", "action", "states", "before", "after"]]


def policy_changes(before, after, interactions: pd.DataFrame, top: int | None = None) -> pd.DataFrame:
    """The participant's contexts (S1-S4), most frequent first (the most recent first among
    equals), ``top`` of them (all by default), and the action of each policy there, in the state
    of the context's latest interaction (its S5-S7: the robot's task, previous action and
    response), so that a policy that was in force then chooses what the robot did. The time of
    day and the time since the last activity read as the tablet writes them (their bins)."""
    cols = ["activity", "scene", "time_slot", "interval"]
    if len(interactions) == 0:
        return pd.DataFrame(columns=cols + ["times", "action_before", "action_after", "changed"])
    ordered = interactions.sort_values(["day", "index"], kind="stable").reset_index(drop=True)
    latest = ordered.groupby(cols)[["task", "previous_action", "previous_response"]].last()
    last_seen = ordered.assign(_last=np.arange(len(ordered))).groupby(cols)["_last"].max()  # its latest row
    freq = (ordered.groupby(cols).size().rename("times").reset_index().join(last_seen, on=cols)
            .sort_values(["times", "_last"], ascending=False, kind="stable").head(top).reset_index(drop=True))
    st = records.policy_states(freq.join(latest, on=cols))
    freq["action_before"] = [spaces.ACTIONS[a] for a in before.greedy(st)]
    freq["action_after"] = [spaces.ACTIONS[a] for a in after.greedy(st)]
    freq["changed"] = freq["action_before"] != freq["action_after"]
    freq["time_slot"] = [spaces.time_slot_label(int(t)) for t in freq["time_slot"]]
    freq["interval"] = [spaces.interval_label(spaces.interval_bin(float(m))) for m in freq["interval"]]
    return freq.drop(columns="_last")

"""``cacas bench``: a quick smoke run writes every key (no timed assertions), bad options are
refused, and the project's fast SAC update computes the same step as the plain reference."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from cacas import spaces
from cacas.bench import METRICS, ReferenceSAC
from cacas.cli import main
from cacas.sac import DiscreteSAC
from unwritable import unwritable_folder  # noqa: F401


def test_quick_bench_prints_the_table_and_writes_every_key(tmp_path, capsys, monkeypatch):
    import cacas.experiment
    import cacas.parallel

    jobs, real = [], cacas.experiment.simulate_study
    monkeypatch.setattr(cacas.parallel, "default_jobs", lambda: 3)  # not 1 even on a one-core machine

    def simulate_study(*args, **kwargs):  # simulate_study_s is timed as `cacas simulate` runs: a worker per core
        jobs.append(kwargs.get("jobs"))
        return real(*args, **kwargs)
    monkeypatch.setattr(cacas.experiment, "simulate_study", simulate_study)
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--quiet", "--json", str(out)]) == 0
    assert jobs and set(jobs) == {3}  # one per core (default_jobs); it was 1, the library's default, since commit 0413037
    printed = capsys.readouterr().out
    data = json.loads(out.read_text())
    for key, _, _ in METRICS:
        assert data[key] > 0, key
        assert key in printed, key
    assert data["machine"]["cores"] >= 1 and data["machine"]["torch"] == torch.__version__
    assert data["sac_speedup"] == pytest.approx(data["sac_updates_per_s"] / data["reference_updates_per_s"])
    assert "machine:" in printed and "QUICK run" in printed
    # the shortened adaptations said as they are: "ORL 30 updates" named a setting gone since commit 579507d
    from cacas.bench import BenchConfig

    quick = BenchConfig.quick().cacaa()
    assert (f"adaptations train 1 simulated day(s), {quick.adapt_updates} SAC updates (ORL as many)" in printed
            and "ORL 30" not in printed)
    # a 1 x 2-day study with shortened adaptations is not the target's size: never "met"
    for key in ("simulate_study_s", "adapt_day_s"):
        (row,) = [line for line in printed.splitlines() if line.startswith(f"| {key} ")]
        assert "quick run, not the target's size" in row and "met" not in row, row
    assert data["not_target_size"] == ["adapt_day_s", "simulate_study_s"]


@pytest.mark.parametrize("argv, message", [
    (["--repeats", "0"], "--repeats 0 is invalid"),
    (["--threads", "0"], "--threads 0 is invalid"),
    # torch.set_num_threads raised a traceback (CLI audit)
    (["--threads", "99999999999999999999"], "--threads 99999999999999999999 is invalid; valid: a whole number from 1 "
                                            "to 256"),
    (["--json", "/no/such/folder/bench.json"],
     "--json /no/such/folder/bench.json: cannot be written there: the folder /no/such/folder does not exist"),
])
def test_bad_options_are_refused(argv, message, capsys):
    assert main(["bench", "--quiet", *argv]) == 2
    assert message in capsys.readouterr().err


def test_an_unwritable_json_path_is_refused_before_measuring(unwritable_folder, monkeypatch, capsys):
    """The message names the file given (not a temporary one) and comes before the benchmark runs."""
    import cacas.bench

    def run_bench(*args, **kwargs):
        raise AssertionError("the benchmark ran before --json was checked")

    monkeypatch.setattr(cacas.bench, "run_bench", run_bench)
    target = unwritable_folder / "b.json"
    assert main(["bench", "--quick", "--quiet", "--json", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"cacas: error: --json {target}: cannot be written there: ")
    assert ".tmp" not in err


def test_a_json_file_that_cannot_be_written_after_measuring_is_named_and_leaves_nothing(tmp_path, monkeypatch, capsys,
                                                                                        fail_on_call):
    """The disk fills up during the minutes of measuring: the message names the user's file (not
    the temporary one), no temporary file stays, and --repeats reaches the benchmark."""
    import pathlib

    import cacas.bench

    seen = []

    class Result:
        def table(self):
            return "| the table |"

        def to_json(self):
            return {"sac_updates_per_s": 1.0}

    def run_bench(cfg, progress):
        seen.append(cfg.repeats)
        return Result()

    monkeypatch.setattr(cacas.bench, "run_bench", run_bench)
    monkeypatch.setattr(pathlib.Path, "replace", fail_on_call(pathlib.Path.replace, 1))
    target = tmp_path / "b.json"
    assert main(["bench", "--quick", "--quiet", "--repeats", "3", "--json", str(target)]) == 2
    err = capsys.readouterr().err
    assert err == f"cacas: error: --json {target}: cannot be written (No space left on device)\n"
    assert seen == [3] and list(tmp_path.iterdir()) == []


def _same_weights(ours: DiscreteSAC) -> ReferenceSAC:
    ref = ReferenceSAC(ours.config, seed=0)
    with torch.no_grad():
        for j, (q, qt) in enumerate(((ref.q1, ref.q1_target), (ref.q2, ref.q2_target))):
            for lin, ens in zip([m for m in q if isinstance(m, torch.nn.Linear)],
                                (ours.critic.l1, ours.critic.l2, ours.critic.l3)):
                lin.weight.copy_(ens.weight[j].t())
                lin.bias.copy_(ens.bias[j, 0])
            qt.load_state_dict(q.state_dict())
        ref.actor.load_state_dict(ours.actor.state_dict())
        ref.log_alpha.copy_(ours.log_alpha)
    return ref


def test_fast_sac_update_equals_the_reference_step():
    """Same weights, same batch (same generator seed): one update (Eq. 1-3, temperature, Polyak)
    gives the same parameters as four autograd-and-Adam steps of the reference."""
    rng = np.random.default_rng(0)
    n = 500
    idx = np.stack([rng.integers(k, size=n) for _, k in spaces.STATE_PARTS], axis=1)
    x, x2 = spaces.encode_states(idx), spaces.encode_states(np.roll(idx, 3, axis=0))
    a, r = rng.integers(spaces.N_ACTIONS, size=n), rng.choice([-1.0, 0.0, 1.0], size=n)
    ours = DiscreteSAC(seed=5)
    ref = _same_weights(ours)
    ours.buffer.add_batch(x, a, r, x2)
    ref.add_batch(x, a, r, x2)
    for _ in range(3):
        ours.generator.manual_seed(11)
        ref.generator.manual_seed(11)
        ours.update(1)
        ref.update(1)
    pairs = [(ours.actor[i].weight, ref.actor[i].weight) for i in (0, 2, 4)]
    pairs += [(ours.critic.l1.weight[1], ref.q2[0].weight.t()), (ours.critic.l3.bias[0, 0], ref.q1[4].bias),
              (ours.critic_target.l2.weight[0], ref.q1_target[2].weight.t()), (ours.log_alpha, ref.log_alpha)]
    for mine, theirs in pairs:
        assert torch.allclose(mine, theirs, atol=1e-5, rtol=1e-4)
    # and the step moved the weights (the comparison is not of untouched tensors)
    assert not torch.allclose(ours.actor[0].weight, DiscreteSAC(seed=5).actor[0].weight)


@pytest.mark.parametrize("option, says", [("--repeats", ["valid: a whole number >= 1", "(default 5"]),
                                          ("--threads", ["valid: a whole number from 1 to 256", "(default 1"])])
def test_bench_help_says_what_is_valid_and_the_default(option, says):
    """CLI audit: --repeats and --threads did not say what the command accepts (it refuses 0)."""
    from cacas.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command").choices["bench"]
    text = " ".join(next(a for a in sub._actions if option in a.option_strings).help.split())
    for s in says:
        assert s in text, text


def test_the_machine_is_described_where_there_is_no_load_average(monkeypatch):
    """Windows has no os.getloadavg (Python: "Availability: Unix"): `cacas bench` ended in an
    AttributeError there before measuring anything. The machine line says there is none."""
    import os

    from cacas.bench import BenchResult, machine_info

    monkeypatch.delattr(os, "getloadavg")
    machine = machine_info(1)
    assert machine["load_average"] == [] and machine["cores"] >= 1
    result = BenchResult(values={key: 1.0 for key, _, _ in METRICS}, repeats={key: 1 for key, _, _ in METRICS},
                         machine={**machine, "load_average_at_start": []}, notes=[])
    assert result.table().splitlines()[-1].endswith(", no load average on this system")

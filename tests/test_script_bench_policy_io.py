"""scripts/bench_policy_io.py prints its table: the import's check of a policy file, the tablet's load of one, and
an import of a small bundle (each a number, the import's of the participants x days asked for)."""

import re

from script_module import load_script


def test_the_policy_benchmark_prints_its_table(capsys):
    assert load_script("bench_policy_io").main(["--participants", "1", "--days", "2", "--repeat", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert re.fullmatch(r"policy file \d+ KB; load average [\d.]+", lines[0])
    assert lines[1:3] == ["| what | median | runs |", "|---|---:|---|"]
    assert [line.split(" | ")[0] for line in lines[3:]] == [
        "| policy_checkpoint (ms a file)", "| policy_from_bytes (ms a file)", "| import of 1 x 2 policies (s)"]
    assert all(float(line.split(" | ")[1]) > 0 for line in lines[3:])

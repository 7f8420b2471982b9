"""Suite-wide settings: torch on one thread (small networks; CI has 2 cores and the browser
tests run a Streamlit server beside the test process)."""

try:
    import torch

    torch.set_num_threads(1)
except ImportError:  # pragma: no cover - torch is a dependency; keep collection robust
    pass


import pytest  # noqa: E402


@pytest.fixture(scope="session")
def small_config():
    """CACAA hyper-parameters shrunk for tests: 1-hour steps, few simulated days."""
    from cacas.adaptation import CACAAConfig
    from cacas.sac import SACConfig

    return CACAAConfig(k_minutes=60, parallel_days=4, initial_train_days=4, adapt_train_days=1, updates_per_step=6,
                       sac=SACConfig(hidden=32, batch_size=64))


@pytest.fixture(scope="session")
def small_initial(small_config):
    from cacas.adaptation import train_initial_policy

    return train_initial_policy(config=small_config, seed=0)


class FailOnCall:
    """A stand-in for ``real`` that raises ``error`` on its ``n``-th call and passes the others
    through; ``calls`` holds each call's first argument (the file, path or descriptor)."""

    def __init__(self, real, n: int, error: Exception):
        self.real, self.n, self.error, self.calls = real, n, error, []

    def __call__(self, *args, **kwargs):
        self.calls.append(args[0] if args else None)
        if len(self.calls) == self.n:
            raise self.error
        return self.real(*args, **kwargs)


DISK_FULL = OSError(28, "No space left on device")


@pytest.fixture
def fail_on_call():
    """``fail_on_call(real, n, error=DISK_FULL)``: a failure part-way through a write (disk full,
    a refused rename), for the "nothing is lost or half-written" tests."""
    return lambda real, n, error=DISK_FULL: FailOnCall(real, n, error)


@pytest.fixture
def case_twin(monkeypatch):
    """``case_twin(store)``: the store gets a participant p01 beside its P01 (whose policy folder
    exists), as only an import of an earlier study could make one (adding refuses it), on a file
    system that does not tell letter case apart (macOS's default): a link stands in for one
    (policies/p01 is policies/P01), and ``files.ignores_letter_case`` is told so (safety audit L4)."""
    from cacas.store import files

    def make(store) -> None:
        with store._conn:
            store._conn.execute("INSERT INTO participants (study_id, code, created_at, updated_at) VALUES "
                                "((SELECT id FROM studies WHERE name = 'default'), 'p01', "
                                "'2026-01-05T10:00:00.000Z', '2026-01-05T10:00:00.000Z')")
        (store.policy_dir / "p01").symlink_to("P01", target_is_directory=True)
        monkeypatch.setattr(files, "ignores_letter_case", lambda folder: True)
    return make

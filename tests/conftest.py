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
    """CACAA hyper-parameters shrunk for tests: 2-hour steps, few simulated days."""
    from cacas.adaptation import CACAAConfig
    from cacas.sac import SACConfig

    return CACAAConfig(k_minutes=60, parallel_days=4, initial_train_days=4, adapt_train_days=1, updates_per_step=6,
                       sac=SACConfig(hidden=32, batch_size=64))


@pytest.fixture(scope="session")
def small_initial(small_config):
    from cacas.adaptation import train_initial_policy

    return train_initial_policy(config=small_config, seed=0)

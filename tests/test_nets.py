import threading

import numpy as np
import torch

from cacas import nets


def _weights(model):
    return [p.detach().clone() for p in model.parameters()]


def test_initial_weights_come_from_the_seed_alone_and_leave_the_global_stream_alone():
    first = _weights(nets.mlp(5, 8, 3, seed=4))
    torch.manual_seed(123)
    torch.rand(1000)  # whatever the process drew before
    state = torch.get_rng_state()
    again = _weights(nets.mlp(5, 8, 3, seed=4))
    assert torch.equal(torch.get_rng_state(), state)
    assert all(torch.equal(a, b) for a, b in zip(first, again))
    other = _weights(nets.mlp(5, 8, 3, seed=5))
    assert not all(torch.equal(a, b) for a, b in zip(first, other))


def test_training_is_seeded_and_leaves_the_global_stream_alone():
    rng = np.random.default_rng(0)
    x = rng.random((40, 5)).astype(np.float32)
    y = (x[:, 0] > 0.5).astype(np.int64)

    def trained():
        return nets.fit_classifier(nets.mlp(5, 8, 2, seed=1), x, y, epochs=150, seed=1)

    a = trained()
    torch.manual_seed(99)
    state = torch.get_rng_state()
    b = trained()
    assert torch.equal(torch.get_rng_state(), state)
    np.testing.assert_array_equal(nets.predict_proba(a, x), nets.predict_proba(b, x))
    assert (nets.predict_proba(a, x).argmax(1) == y).mean() > 0.8


def test_threads_building_networks_at_once_get_the_weights_of_their_seed():
    """The app's background jobs are threads of one process: one job's network must not draw
    from a stream another job just seeded or is drawing from."""
    expected = {seed: _weights(nets.mlp(20, 16, 4, seed=seed)) for seed in (1, 2)}
    wrong = []

    def build(seed):
        for _ in range(150):
            got = _weights(nets.mlp(20, 16, 4, seed=seed))
            if not all(torch.equal(a, b) for a, b in zip(got, expected[seed])):
                wrong.append(seed)
            torch.manual_seed(seed + 10)
            torch.rand(50)  # another job using the global stream meanwhile

    threads = [threading.Thread(target=build, args=(seed,)) for seed in (1, 2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert wrong == []


def test_linear_draws_torchs_default_initialisation_from_its_generator():
    torch.manual_seed(5)
    default = torch.nn.Linear(7, 3)
    layer = nets.linear(7, 3, torch.Generator().manual_seed(5))
    assert torch.equal(layer.weight, default.weight) and torch.equal(layer.bias, default.bias)

import re

import numpy as np
import pytest
import torch

from cacas.errors import CacasError
from cacas.sac import DiscreteSAC, SACConfig


def toy_buffer(agent, n_states=8, n_actions=4, seed=0):
    """A contextual bandit: in state i only action i % n_actions is rewarded (+1), others -1."""
    rng = np.random.default_rng(seed)
    s_idx = rng.integers(n_states, size=2000)
    a = rng.integers(n_actions, size=2000)
    r = np.where(a == s_idx % n_actions, 1.0, -1.0)
    eye = np.eye(n_states, dtype=np.float32)
    agent.buffer.add_batch(eye[s_idx], a, r, eye[rng.integers(n_states, size=2000)])
    return eye


def test_sac_learns_a_toy_task():
    agent = DiscreteSAC(SACConfig(state_dim=8, n_actions=4, hidden=32, batch_size=64, gamma=0.5), seed=1)
    eye = toy_buffer(agent)
    before = agent.greedy(eye)
    agent.update(600)
    assert list(agent.greedy(eye)) == [i % 4 for i in range(8)]
    assert list(before) != [i % 4 for i in range(8)]
    # the critics learnt the reward of the chosen action (gamma * soft value of the next state added)
    q = agent.critic(torch.from_numpy(eye)).min(0).values.detach().numpy()
    assert np.all(q[np.arange(8), np.arange(8) % 4] > q.mean(axis=1))


def test_probabilities_are_distributions_and_greedy_is_argmax():
    agent = DiscreteSAC(seed=0)
    x = np.eye(94, dtype=np.float32)[:5]
    p = agent.action_probabilities(x)
    assert p.shape == (5, 14) and np.allclose(p.sum(1), 1.0, atol=1e-5)
    assert list(agent.greedy(x)) == list(p.argmax(1))


def test_target_entropy_and_temperature_move_towards_target():
    cfg = SACConfig(state_dim=8, n_actions=4, hidden=32, batch_size=64, target_entropy_ratio=0.2)
    agent = DiscreteSAC(cfg, seed=0)
    assert np.isclose(agent.target_entropy, 0.2 * np.log(4))
    toy_buffer(agent)
    info = agent.update(400)
    assert info["entropy"] < 0.6 * np.log(4)  # learnt a clear preference, far from uniform


def test_temperature_rises_below_the_target_entropy_and_falls_above_it():
    """The temperature loss moves alpha so that the policy's entropy tracks the target."""
    cfg = dict(state_dim=8, n_actions=4, hidden=32, batch_size=64)
    low = DiscreteSAC(SACConfig(**cfg, target_entropy_ratio=0.2), seed=0)
    toy_buffer(low)
    alpha0 = low.alpha
    early = low.update(100)
    assert early["entropy"] > low.target_entropy and low.alpha < alpha0  # too random: alpha falls
    alpha1 = low.alpha
    late = low.update(300)
    assert late["entropy"] < low.target_entropy and low.alpha > alpha1  # too sure: alpha rises
    high = DiscreteSAC(SACConfig(**cfg, target_entropy_ratio=0.9), seed=0)
    toy_buffer(high)
    info = high.update(600)
    # a learnt task, yet kept near the high target by a much larger alpha (without it: ~0 nats)
    assert abs(info["entropy"] - high.target_entropy) < 0.15 and high.alpha > 10 * alpha0


def test_save_load_same_policy(tmp_path):
    agent = DiscreteSAC(SACConfig(state_dim=8, n_actions=4, hidden=16), seed=3)
    toy_buffer(agent)
    agent.update(20)
    agent.save(tmp_path / "sac.pt")
    loaded = DiscreteSAC.load(tmp_path / "sac.pt")
    x = np.eye(8, dtype=np.float32)
    assert np.allclose(agent.action_probabilities(x), loaded.action_probabilities(x))
    assert loaded.updates == 20 and np.isclose(loaded.alpha, agent.alpha)
    copy = agent.copy()
    assert np.allclose(copy.action_probabilities(x), agent.action_probabilities(x)) and copy.buffer.size == 0


def test_replay_memory_round_trip_is_compact_and_kept_only_when_asked(tmp_path):
    from cacas import spaces

    agent = DiscreteSAC(seed=0)
    rng = np.random.default_rng(0)
    sizes = [n for _, n in spaces.STATE_PARTS]
    s = np.stack([rng.integers(n, size=50) for n in sizes], axis=1)
    s2 = np.stack([rng.integers(n, size=50) for n in sizes], axis=1)
    a, r = rng.integers(14, size=50), rng.choice([-1.0, 0.0, 1.0], size=50)
    agent.buffer.add_batch(spaces.encode_states(s), a, r, spaces.encode_states(s2))
    memory = agent.replay_memory()
    assert memory["s"].dtype == np.int8 and np.array_equal(memory["s"], s) and np.array_equal(memory["s2"], s2)
    assert np.array_equal(memory["a"], a) and np.array_equal(memory["r"], r)
    agent.memory = memory
    agent.save(tmp_path / "sac.pt")
    loaded = DiscreteSAC.load(tmp_path / "sac.pt")
    assert np.array_equal(loaded.memory["s"], s) and loaded.buffer.size == 0  # kept, not yet replayed
    assert agent.copy().memory is None and agent.copy(keep_memory=True).memory is memory
    loaded.restore_memory(loaded.memory)
    assert loaded.buffer.size == 50 and torch.equal(loaded.buffer.s[:50], agent.buffer.s[:50])
    assert torch.equal(loaded.buffer.r[:50], agent.buffer.r[:50])


def test_an_agent_loaded_to_decide_makes_no_replay_buffer(tmp_path):
    """Scale walk: a policy loaded to decide (the tablet's, the Adaptation page's two, each of an import's 1,260)
    zeroed a 38-MB replay buffer it never fills, half of the load's time; the buffer's tensors are made at their
    first use now, as they were: empty, and holding what is added."""
    agent = DiscreteSAC(seed=0)
    agent.save(tmp_path / "sac.pt")
    loaded = DiscreteSAC.load(tmp_path / "sac.pt")
    assert not {"s", "s2", "a", "r"} & set(vars(loaded.buffer))
    assert loaded.replay_memory()["a"].shape == (0,)  # read before anything is added: empty
    assert loaded.buffer.s.shape == (loaded.config.buffer_capacity, loaded.config.state_dim)
    assert loaded.buffer.a.dtype == torch.long and not loaded.buffer.r.any()
    with pytest.raises(AttributeError):
        loaded.buffer.other


def test_initial_weights_come_from_the_seed_alone_and_leave_the_global_stream_alone():
    import torch

    first = DiscreteSAC(SACConfig(hidden=16), seed=3)
    torch.manual_seed(99)
    torch.rand(100)
    state = torch.get_rng_state()
    again = DiscreteSAC(SACConfig(hidden=16), seed=3)
    assert torch.equal(torch.get_rng_state(), state)
    for a, b in ((first.actor, again.actor), (first.critic, again.critic)):
        assert all(torch.equal(x, y) for x, y in zip(a.parameters(), b.parameters()))
    other = DiscreteSAC(SACConfig(hidden=16), seed=4)
    assert not torch.equal(other.actor[0].weight, first.actor[0].weight)


def test_replay_buffer_clear_empties_it_and_later_samples_are_only_new_transitions():
    # Table III starts every training day with "buffer b = ∅" (run_sac_training clears it per round)
    agent = DiscreteSAC(SACConfig(state_dim=8, n_actions=4, hidden=16), seed=0)
    toy_buffer(agent)
    assert agent.buffer.size == 2000
    agent.buffer.clear()
    assert agent.buffer.size == 0 and agent.buffer.pos == 0
    eye = np.eye(8, dtype=np.float32)
    agent.buffer.add_batch(eye[[5, 6, 7]], np.array([3, 3, 3]), np.array([0.5, 0.5, 0.5]), eye[[0, 1, 2]])
    assert agent.buffer.size == 3 and agent.buffer.pos == 3
    s, a, r, _ = agent.buffer.sample(500, torch.Generator().manual_seed(0))
    assert set(a.tolist()) == {3} and set(r.tolist()) == {0.5}  # nothing from before the clear
    assert set(s.argmax(1).tolist()) == {5, 6, 7}


def _adam_trajectory(monkeypatch, fused: bool):
    """Three FlatAdam steps over two parameter groups with their own learning rates."""
    from cacas import sac

    if not fused:
        monkeypatch.setattr(sac, "_FUSED_ADAM", None)
    gen = torch.Generator().manual_seed(0)
    a, b, c = torch.randn(3, 4, generator=gen), torch.randn(5, generator=gen), torch.randn(2, 2, generator=gen)
    opt = sac.FlatAdam([([a, b], 0.01), ([c], 0.3)])
    for _ in range(3):
        for p, g in zip((a, b, c), opt.grads):
            g.copy_(torch.randn(p.shape, generator=gen))
        opt.step()
    monkeypatch.undo()
    return torch.cat([a.reshape(-1), b, c.reshape(-1)])


def test_flat_adam_without_torchs_fused_kernel_makes_torchs_adam_updates(monkeypatch):
    """FlatAdam falls back to its own update where torch has no ``_fused_adam_`` (a private API):
    the same steps as torch.optim.Adam, group by group (untested, a wrong fallback would change
    every training on such a torch without a word)."""
    gen = torch.Generator().manual_seed(0)
    a, b, c = (torch.randn(3, 4, generator=gen).requires_grad_(), torch.randn(5, generator=gen).requires_grad_(),
               torch.randn(2, 2, generator=gen).requires_grad_())
    ref = torch.optim.Adam([{"params": [a, b], "lr": 0.01}, {"params": [c], "lr": 0.3}])
    for _ in range(3):
        for p in (a, b, c):
            p.grad = torch.randn(p.shape, generator=gen)
        ref.step()
    expected = torch.cat([a.detach().reshape(-1), b.detach(), c.detach().reshape(-1)])
    assert torch.allclose(_adam_trajectory(monkeypatch, fused=False), expected, atol=1e-6)
    assert torch.allclose(_adam_trajectory(monkeypatch, fused=True), expected, atol=1e-6)


def test_zero_updates_leave_the_agent_as_it_was():
    """Helper's bug hunt: update(0) on a filled buffer raised UnboundLocalError ('losses'), e.g. ORL
    with adapt_train_days=0 or sac-user-data with no new transition."""
    agent = DiscreteSAC(SACConfig(hidden=16, batch_size=8), seed=0)
    agent.buffer.add_batch(np.eye(agent.config.state_dim, dtype=np.float32)[:4], np.arange(4), np.ones(4),
                           np.eye(agent.config.state_dim, dtype=np.float32)[1:5])
    before = {k: v.clone() for k, v in agent.actor.state_dict().items()}
    assert agent.update(0) == {}
    assert agent.updates == 0
    assert all(torch.equal(before[k], v) for k, v in agent.actor.state_dict().items())


@pytest.mark.parametrize("field, value, valid", [
    ("state_dim", 0, "a whole number >= 1 (the size of a one-hot state)"),
    ("n_actions", 1, "a whole number >= 2 (the actions the policy chooses from)"),
    ("hidden", 12.5, "a whole number >= 1 (units of each hidden layer)"),
    ("lr", 0, "a number above 0 (Adam's learning rate"),
    ("lr", float("inf"), "a number above 0"),
    ("gamma", 1, "a number from 0 to below 1 (Eq. 2's discount)"),
    ("gamma", -0.1, "a number from 0 to below 1"),
    ("tau", 0, "a number above 0 and at most 1 (the target critics' Polyak step)"),
    ("target_entropy_ratio", 1.2, "a number from 0 to 1 (the target entropy as a share of log(n_actions)"),
    ("initial_alpha", 0.0, "a number above 0 (the temperature at the start, Eq. 3)"),
    ("batch_size", 0, "a whole number >= 1 (transitions sampled for each update)"),
    ("buffer_capacity", "50000", "a whole number >= 1 (transitions the replay buffer holds)"),
])
def test_a_bad_sac_field_is_one_error_naming_field_value_and_valid(field, value, valid):
    """CLI audit: SACConfig took anything (lr 0 never learnt, gamma 1 is no discount in a task without end,
    initial_alpha 0 failed in log(0) when the agent was made)."""
    with pytest.raises(CacasError, match=rf"^{field} {re.escape(repr(value))} is invalid; valid: {re.escape(valid)}"):
        SACConfig(**{field: value})


def test_every_wrong_sac_field_is_said_at_once_and_the_defaults_pass():
    with pytest.raises(CacasError) as exc:
        SACConfig(lr=-1, gamma=2, batch_size=0)
    assert [p.split(" ")[0] for p in str(exc.value).split("; and ")] == ["lr", "gamma", "batch_size"]
    assert SACConfig() == SACConfig(**SACConfig().__dict__)
    assert SACConfig(state_dim=8, n_actions=4, hidden=32, batch_size=64, gamma=0.5, tau=1, lr=np.float32(1e-3),
                     target_entropy_ratio=0, initial_alpha=np.float64(1)).tau == 1

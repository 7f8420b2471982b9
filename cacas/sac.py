"""Discrete Soft Actor-Critic (paper Section IV-B.2, Eq. 1-4).

Twin critics Q_w1, Q_w2 with target copies, a categorical actor pi_theta and a learned temperature
alpha. For a discrete action set the expectations over the next action a_{i+1} ~ pi (Eq. 2) and
over the action a_i ~ pi in the actor loss (Eq. 3) are computed exactly by summing over the 14
actions (Christodoulou, "Soft Actor-Critic for Discrete Action Settings", 2019):

* Eq. 1  L_critic(w_j) = mean_i (y_i - Q_wj(s_i, a_i))^2,  j = 1, 2
* Eq. 2  y_i = r_i + gamma * sum_a' pi(a'|s_{i+1}) [min_j Qbar_wj(s_{i+1}, a') - alpha log pi(a'|s_{i+1})]
* Eq. 3  L_actor(theta) = mean_i sum_a pi(a|s_i) [alpha log pi(a|s_i) - min_j Q_wj(s_i, a)]
* Eq. 4  a = argmax_a pi_theta(a|s)

Eq. 2 as printed, y_i = r_i + gamma min_j Q_wj(s_{i+1}, a_{i+1}) - alpha log pi(a_{i+1}|s_{i+1}),
leaves the entropy term outside the discount and takes the critics themselves. We use the target
of SAC as its reference [18] and Christodoulou define it: the next state's soft value (entropy
term included) discounted as a whole, from the target critics Qbar (the issue asks for "twin
critics with targets"; they keep the targets from chasing the critics). With gamma = 0.1 the
entropy term weighs a tenth of the printed form's in the target.

Temperature: alpha is tuned so that the policy's entropy tracks ``target_entropy_ratio * log|A|``.
The common default 0.98 keeps a 14-action policy almost uniform (entropy 2.59 of a maximum
2.64 nats), so its greedy action (Eq. 4) is decided by noise and, in the reshaped policy (Eq. 5),
the RL part cannot express a preference. We use 0.4 (1.06 nats: the shipped initial policy
puts 57 % on its best action, on average over the 1,144 states of its replay memory), which
keeps exploration during training and a clear greedy action after it.

Discount: in this task the next context (what the person does next) does not depend on the robot's
action, so rewards after the current one carry no information about the action; gamma defaults to
0.1 to keep the critics' targets low-variance (configurable).

Speed: both critics live in one batched "ensemble" network (one matmul per layer for the pair); the
update writes the gradients of Eq. 1 and Eq. 3 out by hand (no autograd graph) into one flat buffer
and one Adam step (:class:`FlatAdam`) updates actor, critics and alpha; the replay buffer is
preallocated tensors. See the README's performance section for the measured effect.
"""

from __future__ import annotations

import io
import math
from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from cacas import nets, spaces
from cacas.checkpoints import load_checkpoint
from cacas.errors import CacasError, check_fields, number_where, share_rule, whole_from


@dataclass
class SACConfig:
    """Discrete SAC's sizes and hyper-parameters (Eq. 1-4; Table III's values as defaults). Every
    field is checked where the config is made (also by ``dataclasses.replace`` and a saved
    policy's config): each wrong one named with its value and what is valid, all at once."""

    state_dim: int = spaces.STATE_DIM
    n_actions: int = spaces.N_ACTIONS
    hidden: int = 128
    lr: float = 3e-3
    gamma: float = 0.1
    tau: float = 0.02
    target_entropy_ratio: float = 0.4
    initial_alpha: float = 0.05
    batch_size: int = 256
    buffer_capacity: int = 50_000

    def __post_init__(self) -> None:
        check_fields(self, SAC_RULES)


#: What each :class:`SACConfig` field takes (:func:`cacas.errors.check_fields`).
SAC_RULES = {
    "state_dim": whole_from(1, "the size of a one-hot state"),
    "n_actions": whole_from(2, "the actions the policy chooses from"),
    "hidden": whole_from(1, "units of each hidden layer"),
    "lr": number_where(lambda v: v > 0, "a number above 0 (Adam's learning rate of the critics, actor and "
                                        "temperature)"),
    "gamma": number_where(lambda v: 0 <= v < 1, "a number from 0 to below 1 (Eq. 2's discount)"),
    "tau": number_where(lambda v: 0 < v <= 1, "a number above 0 and at most 1 (the target critics' Polyak "
                                              "step)"),
    "target_entropy_ratio": share_rule("the target entropy as a share of log(n_actions), a uniform policy's"),
    "initial_alpha": number_where(lambda v: v > 0, "a number above 0 (the temperature at the start, Eq. 3)"),
    "batch_size": whole_from(1, "transitions sampled for each update"),
    "buffer_capacity": whole_from(1, "transitions the replay buffer holds"),
}


class EnsembleLinear(nn.Module):
    """``k`` independent linear layers applied to ``k`` stacked inputs with one batched matmul."""

    def __init__(self, k: int, n_in: int, n_out: int, generator: torch.Generator):
        super().__init__()
        bound = 1.0 / math.sqrt(n_in)
        self.weight = nn.Parameter(torch.empty(k, n_in, n_out).uniform_(-bound, bound, generator=generator))
        self.bias = nn.Parameter(torch.empty(k, 1, n_out).uniform_(-bound, bound, generator=generator))

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # x: (k, n, n_in)
        return torch.baddbmm(self.bias, x, self.weight)


class TwinCritic(nn.Module):
    """Q_w1 and Q_w2 (Eq. 1): two independent MLPs state -> Q over actions, evaluated together."""

    def __init__(self, state_dim: int, n_actions: int, hidden: int, generator: torch.Generator):
        super().__init__()
        self.l1 = EnsembleLinear(2, state_dim, hidden, generator)
        self.l2 = EnsembleLinear(2, hidden, hidden, generator)
        self.l3 = EnsembleLinear(2, hidden, n_actions, generator)

    def forward(self, s: torch.Tensor) -> torch.Tensor:  # -> (2, n, n_actions)
        x = s.unsqueeze(0).expand(2, -1, -1)
        x = F.relu(self.l1(x))
        x = F.relu(self.l2(x))
        return self.l3(x)


def actor_network(state_dim: int, n_actions: int, hidden: int, generator: torch.Generator) -> nn.Sequential:
    """pi_theta: state -> logits over the 14 actions (a categorical policy)."""
    return nets.mlp(state_dim, hidden, n_actions, generator)


class ReplayBuffer:
    """Transitions (s, a, r, s') in preallocated tensors; uniform sampling.

    The tensors (38 MB for 50,000 transitions of 94 features) are made at their first use, not with
    the buffer: an agent loaded to decide (the tablet's policy, the Adaptation page's two versions,
    an import's check of every policy file) never fills one; making them was half of a policy file's
    load (scale walk: an import of 60 participants x 21 days' 1,260 files spent ~40 s on it)."""

    _TENSORS = ("s", "s2", "a", "r")

    def __init__(self, capacity: int, state_dim: int):
        self.capacity, self.state_dim = capacity, state_dim
        self.size = 0
        self.pos = 0

    def __getattr__(self, name: str):  # called only for what is not set yet: the tensors, at their first use
        if name not in ReplayBuffer._TENSORS:
            raise AttributeError(name)
        self.s = torch.zeros(self.capacity, self.state_dim)
        self.s2 = torch.zeros(self.capacity, self.state_dim)
        self.a = torch.zeros(self.capacity, dtype=torch.long)
        self.r = torch.zeros(self.capacity)
        return getattr(self, name)

    def add_batch(self, s: np.ndarray, a: np.ndarray, r: np.ndarray, s2: np.ndarray) -> None:
        n = len(a)
        idx = (self.pos + np.arange(n)) % self.capacity
        t = torch.from_numpy
        self.s[idx] = t(np.asarray(s, np.float32))
        self.s2[idx] = t(np.asarray(s2, np.float32))
        self.a[idx] = t(np.asarray(a, np.int64))
        self.r[idx] = t(np.asarray(r, np.float32))
        self.pos = int((self.pos + n) % self.capacity)
        self.size = int(min(self.size + n, self.capacity))

    def clear(self) -> None:
        """Empty the buffer (Table III: "buffer b = ∅" at the start of every training day).
        The preallocated tensors stay; what they still hold is never sampled again."""
        self.size = 0
        self.pos = 0

    def sample(self, batch_size: int, generator: torch.Generator):
        idx = torch.randint(0, self.size, (batch_size,), generator=generator)
        take = torch.index_select  # the same rows as self.s[idx], without advanced-indexing overhead
        return take(self.s, 0, idx), take(self.a, 0, idx), take(self.r, 0, idx), take(self.s2, 0, idx)


# --- the update's forward and backward passes, written out (used under torch.no_grad) --------------
# relu'(x) from relu's output: what autograd's ReLU backward computes.
_relu_backward = torch.ops.aten.threshold_backward


def _log_softmax(z: torch.Tensor) -> torch.Tensor:
    """log pi = z - logsumexp(z) over the actions (faster than F.log_softmax for 14 columns)."""
    return z - z.logsumexp(-1, keepdim=True)


def _mlp_forward(layers, x: torch.Tensor) -> list[torch.Tensor]:
    """Hidden activations and output of an nn.Linear/ReLU MLP (the actor): [h1, h2, ..., logits]."""
    out = []
    for i, (w, b) in enumerate(layers):
        x = torch.addmm(b, x, w.t())
        if i < len(layers) - 1:
            x = x.relu_()
        out.append(x)
    return out


def _mlp_backward(layers, grads, inputs, g: torch.Tensor) -> None:
    """Write dL/dW, dL/db of every layer into ``grads`` given dL/d(output) ``g``; ``inputs`` are
    each layer's input (x, h1, h2, ...)."""
    for i in range(len(layers) - 1, -1, -1):
        w = layers[i][0]
        gw, gb = grads[i]
        torch.mm(g.t(), inputs[i], out=gw)
        torch.sum(g, 0, out=gb)
        if i:
            g = _relu_backward(torch.mm(g, w), inputs[i], 0.0)


def _ensemble_forward(layers, s: torch.Tensor) -> list[torch.Tensor]:
    """TwinCritic's forward for both members: [h1, h2, Q] with shapes (2, n, .)."""
    x = s.unsqueeze(0).expand(len(layers[0][0]), -1, -1)
    out = []
    for i, (w, b) in enumerate(layers):
        x = torch.baddbmm(b, x, w)
        if i < len(layers) - 1:
            x = x.relu_()
        out.append(x)
    return out


def _ensemble_backward(layers, grads, inputs, g: torch.Tensor) -> None:
    """The ensemble version of :func:`_mlp_backward` (weights (k, in, out), biases (k, 1, out))."""
    for i in range(len(layers) - 1, -1, -1):
        w = layers[i][0]
        gw, gb = grads[i]
        torch.bmm(inputs[i].transpose(1, 2), g, out=gw)
        torch.sum(g, 1, keepdim=True, out=gb)
        if i:
            g = _relu_backward(torch.bmm(g, w.transpose(1, 2)), inputs[i], 0.0)


#: The kernel behind ``torch.optim.Adam(fused=True)`` (without its per-call Python bookkeeping).
_FUSED_ADAM = getattr(torch, "_fused_adam_", None)


class FlatAdam:
    """Adam (the update of ``torch.optim.Adam``, no weight decay) over parameter groups whose
    tensors are re-pointed into one flat buffer, with one flat gradient buffer: a step is a
    handful of vector operations however many tensors there are. ``groups``: (params, lr) pairs.
    ``grads[i]`` is the gradient view of the i-th parameter (in group order), to be written."""

    def __init__(self, groups, betas: tuple[float, float] = (0.9, 0.999), eps: float = 1e-8):
        params = [p for ps, _ in groups for p in ps]
        total = sum(p.numel() for p in params)
        self.flat = torch.zeros(total)
        self.grad = torch.zeros(total)
        self.exp_avg = torch.zeros(total)
        self.exp_avg_sq = torch.zeros(total)
        self.grads: list[torch.Tensor] = []
        self.ranges: list[tuple[int, int, float]] = []
        off = 0
        for ps, lr in groups:
            start = off
            for p in ps:
                k = p.numel()
                self.flat[off:off + k].copy_(p.detach().reshape(-1))
                p.data = self.flat[off:off + k].view_as(p)
                self.grads.append(self.grad[off:off + k].view_as(p))
                off += k
            self.ranges.append((start, off, lr))
        self.betas, self.eps = betas, eps
        self.steps = 0
        self._step_tensor = torch.zeros(())
        self._slices = [tuple(t[start:end] for t in (self.flat, self.grad, self.exp_avg, self.exp_avg_sq)) + (lr,)
                        for start, end, lr in self.ranges]

    def step(self) -> None:
        b1, b2 = self.betas
        self.steps += 1
        if _FUSED_ADAM is not None:  # torch's own fused Adam kernel: one pass over the buffers
            self._step_tensor.fill_(self.steps)
            for flat, grad, exp_avg, exp_avg_sq, lr in self._slices:
                _FUSED_ADAM([flat], [grad], [exp_avg], [exp_avg_sq], [], [self._step_tensor], lr=lr, beta1=b1,
                            beta2=b2, weight_decay=0.0, eps=self.eps, amsgrad=False, maximize=False)
            return
        self.exp_avg.lerp_(self.grad, 1 - b1)
        self.exp_avg_sq.mul_(b2).addcmul_(self.grad, self.grad, value=1 - b2)
        bias1 = 1 - b1 ** self.steps
        denom = (self.exp_avg_sq.sqrt() / math.sqrt(1 - b2 ** self.steps)).add_(self.eps)
        for start, end, lr in self.ranges:
            self.flat[start:end].addcdiv_(self.exp_avg[start:end], denom[start:end], value=-lr / bias1)


class DiscreteSAC:
    """The SAC agent of Eq. 1-4 with save/load."""

    def __init__(self, config: SACConfig | None = None, seed: int = 0):
        self.config = config or SACConfig()
        c = self.config
        self.generator = torch.Generator().manual_seed(seed)  # replay sampling
        init = torch.Generator().manual_seed(seed)  # initial weights: from the seed alone, never the global stream
        self.actor = actor_network(c.state_dim, c.n_actions, c.hidden, init)
        self.critic = TwinCritic(c.state_dim, c.n_actions, c.hidden, init)
        self.critic_target = TwinCritic(c.state_dim, c.n_actions, c.hidden, init)
        self.critic_target.load_state_dict(self.critic.state_dict())
        for p in self.critic_target.parameters():
            p.requires_grad_(False)
        self.log_alpha = torch.tensor(math.log(c.initial_alpha), requires_grad=True)
        self.target_entropy = c.target_entropy_ratio * math.log(c.n_actions)
        self._make_optimizers()
        self.buffer = ReplayBuffer(c.buffer_capacity, c.state_dim)
        self.updates = 0
        #: the replay memory this agent keeps across adaptations (compact, see replay_memory());
        #: set for the initial policy (its step-1 experience) and carried by ORL.
        self.memory: dict[str, np.ndarray] | None = None

    def _make_optimizers(self) -> None:
        """One Adam over the actor, both critics and log alpha (3x the learning rate), whose
        parameters are views into one flat buffer (see :class:`FlatAdam`)."""
        lr = self.config.lr
        self.optimizer = FlatAdam([(list(self.actor.parameters()) + list(self.critic.parameters()), lr),
                                   ([self.log_alpha], 3 * lr)])
        self._critic_params = list(self.critic.parameters())
        self._target_params = list(self.critic_target.parameters())
        a_w = [m for m in self.actor if isinstance(m, nn.Linear)]
        self._actor_layers = [(m.weight, m.bias) for m in a_w]
        self._critic_layers = [(m.weight, m.bias) for m in (self.critic.l1, self.critic.l2, self.critic.l3)]
        self._target_layers = [(m.weight, m.bias) for m in
                               (self.critic_target.l1, self.critic_target.l2, self.critic_target.l3)]
        grads = self.optimizer.grads
        n_a = len(self._actor_layers)
        self._actor_grads = [(grads[2 * i], grads[2 * i + 1]) for i in range(n_a)]
        self._critic_grads = [(grads[2 * n_a + 2 * i], grads[2 * n_a + 2 * i + 1]) for i in range(3)]
        self._alpha_grad = grads[-1]

    @property
    def alpha(self) -> float:
        return float(self.log_alpha.detach().exp())

    # --- acting ------------------------------------------------------------------------------------
    @torch.no_grad()
    def action_probabilities(self, states: np.ndarray) -> np.ndarray:
        """pi_theta(.|s) for a batch of 94-D states: (n, 14) rows summing to 1."""
        x = torch.as_tensor(np.asarray(states, np.float32))
        return torch.softmax(self.actor(x), dim=-1).numpy()

    def greedy(self, states: np.ndarray) -> np.ndarray:
        """Eq. 4: the action of maximum probability."""
        return self.action_probabilities(states).argmax(axis=1)

    # --- learning ----------------------------------------------------------------------------------
    def update(self, n_updates: int = 1) -> dict[str, float]:
        """``n_updates`` gradient steps of Eq. 1 (critics), Eq. 3 (actor) and the temperature.

        Speed (the same mathematics as autograd over the three losses with one Adam per part):
        the gradients of these small MLPs are written out by hand (no autograd graph), into one
        flat gradient buffer, and one Adam step updates every parameter with a few vector ops.
        The critic and actor losses have disjoint parameters, so one step for all equals the
        separate steps. ``tests/test_bench.py`` checks the update against the plain reference.
        """
        c = self.config
        if self.buffer.size == 0 or n_updates < 1:  # nothing to learn from, or no update asked for
            return {}
        with torch.no_grad():
            for _ in range(n_updates):
                losses = self._update_once(c)
        return {k: float(v) for k, v in zip(("critic_loss", "actor_loss", "entropy", "alpha"), losses)}

    def _update_once(self, c: SACConfig) -> dict[str, float]:
        s, a, r, s2 = self.buffer.sample(c.batch_size, self.generator)
        n = s.shape[0]
        alpha = self.log_alpha.exp()
        # Eq. 2: y = r + gamma * sum_a' pi(a'|s') [min_j Qbar_j(s', a') - alpha log pi(a'|s')]
        logp2 = _log_softmax(_mlp_forward(self._actor_layers, s2)[-1])
        q2 = _ensemble_forward(self._target_layers, s2)[-1].min(0).values
        y = r + c.gamma * (logp2.exp() * (q2 - alpha * logp2)).sum(-1)
        # Eq. 1 for j = 1, 2: L = sum_j mean_i (Q_j(s_i, a_i) - y_i)^2, and its gradient
        xs = s.unsqueeze(0).expand(2, -1, -1)
        c1, c2, q = _ensemble_forward(self._critic_layers, s)
        idx = a.view(1, -1, 1).expand(2, -1, 1)
        diff = q.gather(2, idx).squeeze(2) - y
        critic_loss = (diff * diff).mean(1).sum()
        gq = torch.zeros_like(q).scatter_(2, idx, diff.unsqueeze(2) * (2.0 / n))
        _ensemble_backward(self._critic_layers, self._critic_grads, (xs, c1, c2), gq)
        # Eq. 3: L = mean_i sum_a pi(a|s_i) [alpha log pi(a|s_i) - min_j Q_j(s_i, a)];
        # d/dz_k of sum_a p_a c_a (c_a = alpha log p_a - Q_a) is p_k (c_k - sum_a p_a c_a).
        h1, h2, z = _mlp_forward(self._actor_layers, s)
        logp = _log_softmax(z)
        p = logp.exp()
        cost = alpha * logp - q.min(0).values
        pc = p * cost
        per_state = pc.sum(-1, keepdim=True)
        actor_loss = per_state.mean()
        gz = p * (cost - per_state)
        gz.mul_(1.0 / n)
        _mlp_backward(self._actor_layers, self._actor_grads, (s, h1, h2), gz)
        # temperature: d/d log alpha of log_alpha * (H - H_target)
        entropy = -(p * logp).sum(-1).mean()
        torch.sub(entropy, self.target_entropy, out=self._alpha_grad.view(()))
        self.optimizer.step()
        torch._foreach_lerp_(self._target_params, self._critic_params, c.tau)  # Polyak averaging
        self.updates += 1
        return critic_loss, actor_loss, entropy, alpha

    # --- replay memory -----------------------------------------------------------------------------
    def replay_memory(self) -> dict[str, np.ndarray]:
        """The replay buffer's transitions in compact form: s and s' as Table I index rows (int8),
        the action (int8) and the reward (float32); about 16 bytes a transition."""
        b, n = self.buffer, self.buffer.size
        return {"s": spaces.indices_from_onehot(b.s[:n].numpy()).astype(np.int8),
                "a": b.a[:n].numpy().astype(np.int8), "r": b.r[:n].numpy().astype(np.float32),
                "s2": spaces.indices_from_onehot(b.s2[:n].numpy()).astype(np.int8)}

    def restore_memory(self, memory: dict[str, np.ndarray]) -> None:
        """Put a compact replay memory (:meth:`replay_memory`) back into the replay buffer."""
        if len(memory["a"]):
            self.buffer.add_batch(spaces.encode_states(memory["s"].astype(np.int64)), memory["a"].astype(np.int64),
                                  memory["r"], spaces.encode_states(memory["s2"].astype(np.int64)))

    # --- persistence -------------------------------------------------------------------------------
    def state_dict(self) -> dict:
        """Weights, temperature and, when the agent keeps one, its compact replay memory."""
        state = {"config": asdict(self.config), "actor": self.actor.state_dict(),
                 "critic": self.critic.state_dict(), "critic_target": self.critic_target.state_dict(),
                 "log_alpha": self.log_alpha.detach().clone(), "updates": self.updates}
        if self.memory is not None:
            state["memory"] = self.memory
        return state

    @classmethod
    def from_state_dict(cls, state: dict, seed: int = 0) -> "DiscreteSAC":
        agent = cls(SACConfig(**state["config"]), seed=seed)
        agent.actor.load_state_dict(state["actor"])
        agent.critic.load_state_dict(state["critic"])
        agent.critic_target.load_state_dict(state["critic_target"])
        with torch.no_grad():
            agent.log_alpha.copy_(state["log_alpha"])
        agent.updates = int(state["updates"])
        agent.memory = state.get("memory")
        return agent

    def copy(self, seed: int = 0, keep_memory: bool = False, config: SACConfig | None = None) -> "DiscreteSAC":
        """A fresh agent with the same weights and temperature (empty replay buffer, new
        optimizers); with ``keep_memory`` it carries the same kept replay memory (not yet in its
        buffer). ``config``: the learning settings it goes on with (learning rate, discount,
        target entropy, ...; default this agent's); its network sizes must be this agent's."""
        state = {**self.state_dict(), "memory": None}
        if config is not None:
            shape = ("state_dim", "n_actions", "hidden")
            differ = [f"{f} {getattr(config, f)} (the agent's: {getattr(self.config, f)})" for f in shape
                      if getattr(config, f) != getattr(self.config, f)]
            if differ:
                raise CacasError(f"the SAC settings do not fit this agent's networks: {', '.join(differ)}; valid: "
                                 f"the agent's sizes ({', '.join(f'{f} {getattr(self.config, f)}' for f in shape)})")
            state["config"] = asdict(config)
        agent = DiscreteSAC.from_state_dict(state, seed=seed)
        agent.memory = self.memory if keep_memory else None
        return agent

    def save(self, path) -> None:
        torch.save(self.state_dict(), path)

    @classmethod
    def load(cls, path) -> "DiscreteSAC":
        return cls.from_state_dict(load_checkpoint(path))  # weights only: runs no code

    def to_bytes(self) -> bytes:
        buf = io.BytesIO()
        torch.save(self.state_dict(), buf)
        return buf.getvalue()

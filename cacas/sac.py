"""Discrete Soft Actor-Critic (paper Section IV-B.2, Eq. 1-4).

Twin critics Q_w1, Q_w2 with target copies, a categorical actor pi_theta and a learned temperature
alpha. For a discrete action set the expectations over the next action a_{i+1} ~ pi (Eq. 2) and
over the action a_i ~ pi in the actor loss (Eq. 3) are computed exactly by summing over the 14
actions (Christodoulou, "Soft Actor-Critic for Discrete Action Settings", 2019):

* Eq. 1  L_critic(w_j) = mean_i (y_i - Q_wj(s_i, a_i))^2,  j = 1, 2
* Eq. 2  y_i = r_i + gamma * sum_a' pi(a'|s_{i+1}) [min_j Qbar_wj(s_{i+1}, a') - alpha log pi(a'|s_{i+1})]
* Eq. 3  L_actor(theta) = mean_i sum_a pi(a|s_i) [alpha log pi(a|s_i) - min_j Q_wj(s_i, a)]
* Eq. 4  a = argmax_a pi_theta(a|s)

Temperature: alpha is tuned so that the policy's entropy tracks ``target_entropy_ratio * log|A|``.
The common default 0.98 keeps a 14-action policy almost uniform (entropy 2.59 of a maximum
2.64 nats), so its greedy action (Eq. 4) is decided by noise and, in the reshaped policy (Eq. 5),
the RL part cannot express a preference. We use 0.4 (1.06 nats: roughly 70 % on the best action
once learnt), which keeps exploration during training and a clear greedy action after it.

Discount: in this task the next context (what the person does next) does not depend on the robot's
action, so rewards after the current one carry no information about the action; gamma defaults to
0.1 to keep the critics' targets low-variance (configurable).

Speed: both critics live in one batched "ensemble" network (one matmul per layer for the pair) and
share one Adam optimizer; the replay buffer is preallocated tensors; no per-update Python loops.
"""

from __future__ import annotations

import io
import math
from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from cacas import spaces


@dataclass
class SACConfig:
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


class EnsembleLinear(nn.Module):
    """``k`` independent linear layers applied to ``k`` stacked inputs with one batched matmul."""

    def __init__(self, k: int, n_in: int, n_out: int):
        super().__init__()
        bound = 1.0 / math.sqrt(n_in)
        self.weight = nn.Parameter(torch.empty(k, n_in, n_out).uniform_(-bound, bound))
        self.bias = nn.Parameter(torch.empty(k, 1, n_out).uniform_(-bound, bound))

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # x: (k, n, n_in)
        return torch.baddbmm(self.bias, x, self.weight)


class TwinCritic(nn.Module):
    """Q_w1 and Q_w2 (Eq. 1): two independent MLPs state -> Q over actions, evaluated together."""

    def __init__(self, state_dim: int, n_actions: int, hidden: int):
        super().__init__()
        self.l1 = EnsembleLinear(2, state_dim, hidden)
        self.l2 = EnsembleLinear(2, hidden, hidden)
        self.l3 = EnsembleLinear(2, hidden, n_actions)

    def forward(self, s: torch.Tensor) -> torch.Tensor:  # -> (2, n, n_actions)
        x = s.unsqueeze(0).expand(2, -1, -1)
        x = F.relu(self.l1(x))
        x = F.relu(self.l2(x))
        return self.l3(x)


def actor_network(state_dim: int, n_actions: int, hidden: int) -> nn.Sequential:
    """pi_theta: state -> logits over the 14 actions (a categorical policy)."""
    return nn.Sequential(nn.Linear(state_dim, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                         nn.Linear(hidden, n_actions))


class ReplayBuffer:
    """Transitions (s, a, r, s') in preallocated tensors; uniform sampling."""

    def __init__(self, capacity: int, state_dim: int):
        self.capacity = capacity
        self.s = torch.zeros(capacity, state_dim)
        self.s2 = torch.zeros(capacity, state_dim)
        self.a = torch.zeros(capacity, dtype=torch.long)
        self.r = torch.zeros(capacity)
        self.size = 0
        self.pos = 0

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

    def sample(self, batch_size: int, generator: torch.Generator):
        idx = torch.randint(0, self.size, (batch_size,), generator=generator)
        return self.s[idx], self.a[idx], self.r[idx], self.s2[idx]


class DiscreteSAC:
    """The SAC agent of Eq. 1-4 with save/load."""

    def __init__(self, config: SACConfig | None = None, seed: int = 0):
        self.config = config or SACConfig()
        c = self.config
        torch.manual_seed(seed)
        self.generator = torch.Generator().manual_seed(seed)
        self.actor = actor_network(c.state_dim, c.n_actions, c.hidden)
        self.critic = TwinCritic(c.state_dim, c.n_actions, c.hidden)
        self.critic_target = TwinCritic(c.state_dim, c.n_actions, c.hidden)
        self.critic_target.load_state_dict(self.critic.state_dict())
        for p in self.critic_target.parameters():
            p.requires_grad_(False)
        self.log_alpha = torch.tensor(math.log(c.initial_alpha), requires_grad=True)
        self.target_entropy = c.target_entropy_ratio * math.log(c.n_actions)
        self._make_optimizers()
        self.buffer = ReplayBuffer(c.buffer_capacity, c.state_dim)
        self.updates = 0

    def _make_optimizers(self) -> None:
        lr = self.config.lr
        self.critic_opt = torch.optim.Adam(self.critic.parameters(), lr=lr, foreach=True)
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=lr, foreach=True)
        self.alpha_opt = torch.optim.Adam([self.log_alpha], lr=3 * lr)

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
        """``n_updates`` gradient steps of Eq. 1 (critics), Eq. 3 (actor) and the temperature."""
        c = self.config
        if self.buffer.size == 0:
            return {}
        info = {}
        for _ in range(n_updates):
            s, a, r, s2 = self.buffer.sample(c.batch_size, self.generator)
            alpha = self.log_alpha.exp().detach()
            with torch.no_grad():  # Eq. 2 (expectation over a_{i+1} ~ pi)
                logits2 = self.actor(s2)
                logp2 = F.log_softmax(logits2, -1)
                q2 = self.critic_target(s2).min(0).values
                v2 = (logp2.exp() * (q2 - alpha * logp2)).sum(-1)
                y = r + c.gamma * v2
            q = self.critic(s)  # (2, n, A)
            q_a = q.gather(2, a.view(1, -1, 1).expand(2, -1, 1)).squeeze(2)
            critic_loss = ((q_a - y.unsqueeze(0)) ** 2).mean(1).sum()  # Eq. 1 for j = 1, 2
            self.critic_opt.zero_grad(set_to_none=True)
            critic_loss.backward()
            self.critic_opt.step()

            logp = F.log_softmax(self.actor(s), -1)
            p = logp.exp()
            q_min = q.detach().min(0).values
            actor_loss = (p * (alpha * logp - q_min)).sum(-1).mean()  # Eq. 3
            self.actor_opt.zero_grad(set_to_none=True)
            actor_loss.backward()
            self.actor_opt.step()

            entropy = -(p.detach() * logp.detach()).sum(-1).mean()
            alpha_loss = self.log_alpha * (entropy - self.target_entropy)
            self.alpha_opt.zero_grad(set_to_none=True)
            alpha_loss.backward()
            self.alpha_opt.step()

            with torch.no_grad():  # Polyak averaging of the target critics
                for pt, pc in zip(self.critic_target.parameters(), self.critic.parameters()):
                    pt.lerp_(pc, c.tau)
            self.updates += 1
            info = {"critic_loss": float(critic_loss.detach()), "actor_loss": float(actor_loss.detach()),
                    "entropy": float(entropy), "alpha": float(alpha)}
        return info

    # --- persistence -------------------------------------------------------------------------------
    def state_dict(self) -> dict:
        return {"config": asdict(self.config), "actor": self.actor.state_dict(),
                "critic": self.critic.state_dict(), "critic_target": self.critic_target.state_dict(),
                "log_alpha": self.log_alpha.detach().clone(), "updates": self.updates}

    @classmethod
    def from_state_dict(cls, state: dict, seed: int = 0) -> "DiscreteSAC":
        agent = cls(SACConfig(**state["config"]), seed=seed)
        agent.actor.load_state_dict(state["actor"])
        agent.critic.load_state_dict(state["critic"])
        agent.critic_target.load_state_dict(state["critic_target"])
        with torch.no_grad():
            agent.log_alpha.copy_(state["log_alpha"])
        agent.updates = int(state["updates"])
        return agent

    def copy(self, seed: int = 0) -> "DiscreteSAC":
        """A fresh agent with the same weights (empty replay buffer, new optimizers)."""
        return DiscreteSAC.from_state_dict(self.state_dict(), seed=seed)

    def save(self, path) -> None:
        torch.save(self.state_dict(), path)

    @classmethod
    def load(cls, path) -> "DiscreteSAC":
        return cls.from_state_dict(torch.load(path, weights_only=False))

    def to_bytes(self) -> bytes:
        buf = io.BytesIO()
        torch.save(self.state_dict(), buf)
        return buf.getvalue()

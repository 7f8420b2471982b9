"""Small multi-layer perceptrons and their supervised training (the user model and MLP_policy)."""

from __future__ import annotations

import math

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F


def mlp(n_in: int, hidden: int, n_out: int, seed: int | torch.Generator) -> nn.Sequential:
    """n_in -> hidden (ReLU) -> hidden (ReLU) -> n_out logits, its initial weights drawn from a
    generator of its own seeded with ``seed`` (or from the generator given, which goes on to
    other networks): torch's global random stream is neither read nor changed, so the network
    does not depend on what the process, or another thread of it (the app's background jobs),
    did before or does meanwhile."""
    g = seed if isinstance(seed, torch.Generator) else torch.Generator().manual_seed(seed)
    return nn.Sequential(linear(n_in, hidden, g), nn.ReLU(), linear(hidden, hidden, g), nn.ReLU(),
                         linear(hidden, n_out, g))


@torch.no_grad()
def linear(n_in: int, n_out: int, generator: torch.Generator) -> nn.Linear:
    """An ``nn.Linear`` with torch's default initialisation (weight and bias uniform in
    +-1/sqrt(n_in), i.e. kaiming-uniform with a = sqrt(5)) drawn from ``generator`` alone; built
    on the meta device first, so that nothing is drawn from the global stream."""
    layer = nn.Linear(n_in, n_out, device="meta").to_empty(device="cpu")
    nn.init.kaiming_uniform_(layer.weight, a=math.sqrt(5), generator=generator)
    bound = 1 / math.sqrt(n_in)
    nn.init.uniform_(layer.bias, -bound, bound, generator=generator)
    return layer


def fit_classifier(model: nn.Module, x: np.ndarray, y: np.ndarray, epochs: int = 150, lr: float = 1e-2,
                   weight_decay: float = 1e-4, batch_size: int = 256, seed: int = 0,
                   sample_weight: np.ndarray | None = None) -> nn.Module:
    """Cross-entropy training with Adam (full batch when the data are small, as here)."""
    g = torch.Generator().manual_seed(seed)
    xt = torch.as_tensor(np.asarray(x, np.float32))
    yt = torch.as_tensor(np.asarray(y, np.int64))
    wt = None if sample_weight is None else torch.as_tensor(np.asarray(sample_weight, np.float32))
    opt = torch.optim.Adam(model.parameters(), lr=lr, weight_decay=weight_decay)
    n = len(xt)
    model.train()
    for _ in range(epochs):
        order = torch.randperm(n, generator=g) if n > batch_size else torch.arange(n)
        for start in range(0, n, batch_size):
            idx = order[start:start + batch_size]
            loss = F.cross_entropy(model(xt[idx]), yt[idx], reduction="none")
            loss = (loss * wt[idx]).sum() / wt[idx].sum() if wt is not None else loss.mean()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
    model.eval()
    return model


@torch.no_grad()
def predict_proba(model: nn.Module, x: np.ndarray) -> np.ndarray:
    return torch.softmax(model(torch.as_tensor(np.asarray(x, np.float32))), -1).numpy()

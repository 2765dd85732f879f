"""Density-based feasibility from feasible assemblies only: a normalizing flow on embeddings.

The paper's follow-up idea (its feasibility study, Sec. V-B.3, notes that GRACE trained on
feasible assemblies alone cannot tell infeasible ones): model the density of the mean-pooled
GRACE embeddings of feasible assemblies, and call an assembly infeasible where that density is
low. The flow is zuko's masked autoregressive flow (MAF): zuko is maintained, pure PyTorch (no
second autodiff stack beside the torch we pin) and small; the training loop is ours because
zuko leaves it to the user. `FlowDensity` follows scikit-learn's density-estimator interface
(`fit`, `score_samples`, as KernelDensity or GaussianMixture), so a config can put it behind a
StandardScaler / PCA pipeline or swap in a scikit-learn density as a reference.
"""

from __future__ import annotations

import copy

import numpy as np
import torch
import zuko
from sklearn.base import BaseEstimator


class FlowDensity(BaseEstimator):
    """MAF density fitted by maximum likelihood with Adam, early-stopped on held-out points.

    `val_fraction` of the fitting points (seeded) are held out; training stops after `patience`
    epochs without a better held-out log-likelihood and keeps the best weights. Full-batch: the
    fitting sets are a few thousand points of a few dozen dimensions.
    """

    def __init__(
        self,
        transforms: int = 3,
        hidden: tuple[int, ...] = (64, 64),
        epochs: int = 500,
        lr: float = 1e-3,
        weight_decay: float = 1e-4,
        val_fraction: float = 0.2,
        patience: int = 30,
        seed: int = 0,
    ) -> None:
        self.transforms = transforms
        self.hidden = hidden
        self.epochs = epochs
        self.lr = lr
        self.weight_decay = weight_decay
        self.val_fraction = val_fraction
        self.patience = patience
        self.seed = seed

    def fit(self, x: np.ndarray, y: object = None) -> FlowDensity:
        """Fit the flow to the rows of `x` (`y` is ignored, as in scikit-learn densities).

        Runs on one thread: the problem is tiny, and on two busy cores a second thread made a fit
        13× slower here (thread spinning), whatever torch's setting elsewhere; restored after.
        """
        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            return self._fit(np.asarray(x, dtype=np.float32))
        finally:
            torch.set_num_threads(threads)

    def _fit(self, x: np.ndarray) -> FlowDensity:
        if x.ndim != 2 or len(x) < 2:
            raise ValueError(f"FlowDensity.fit: need ≥ 2 rows of features, got shape {x.shape}")
        rng = np.random.default_rng(self.seed)
        order = rng.permutation(len(x))
        n_val = round(self.val_fraction * len(x))
        fit_x = torch.from_numpy(x[order[n_val:]])
        val_x = torch.from_numpy(x[order[:n_val]]) if n_val else fit_x
        with torch.random.fork_rng():
            torch.manual_seed(self.seed)
            flow = zuko.flows.MAF(
                x.shape[1], transforms=self.transforms, hidden_features=tuple(self.hidden)
            )
        optimiser = torch.optim.Adam(flow.parameters(), lr=self.lr, weight_decay=self.weight_decay)
        best, best_state, waited = -np.inf, copy.deepcopy(flow.state_dict()), 0
        for _ in range(self.epochs):
            optimiser.zero_grad()
            loss = -flow().log_prob(fit_x).mean()
            loss.backward()
            optimiser.step()
            with torch.no_grad():
                held_out = float(flow().log_prob(val_x).mean())
            if held_out > best:
                best, best_state, waited = held_out, copy.deepcopy(flow.state_dict()), 0
            else:
                waited += 1
                if waited >= self.patience:
                    break
        flow.load_state_dict(best_state)
        self.flow_ = flow.eval()
        self.n_features_in_ = x.shape[1]
        return self

    def score_samples(self, x: np.ndarray) -> np.ndarray:
        """Log-likelihood of each row of `x` under the fitted flow."""
        with torch.no_grad():
            log_prob = self.flow_().log_prob(torch.as_tensor(np.asarray(x), dtype=torch.float32))
        return log_prob.numpy().astype(np.float64)

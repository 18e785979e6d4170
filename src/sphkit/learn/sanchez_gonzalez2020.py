"""Graph network simulator (GNS): Sanchez-Gonzalez, Godwin, Pfaff, Ying, Leskovec, Battaglia,
"Learning to Simulate Complex Physics with Graph Networks", ICML 2020.

The encode-process-decode network of the paper (Sec. 2, "Model"; Fig. 2), as LagrangeBench
(Toshev et al. 2023, ``lagrangebench/models/gns.py``) implements it:

* **Graph** (Sec. 2, "Encoder"): particles within the connectivity radius R are connected
  (:mod:`sphkit.learn.graph`, sphkit's neighbour search on the current, noisy, positions).
* **Node features** (Sec. 2; Appendix "Input and output representations"): the last C = 5
  velocities ``x[t-k] - x[t-k-1]`` normalised with the dataset statistics (by default passed
  as the last velocity and the 4 frame accelerations between them, see ``GNSConfig.history``:
  the same information, better scaled), the distances to the
  lower and upper bounds of the domain divided by R and clipped to [-1, 1], and a learned
  embedding (16 numbers) of the particle type.
* **Edge features**: the relative displacement ``(x_s - x_r) / R`` and its norm.
* **Encoder**: MLPs map node and edge features to latent vectors of size L.
* **Processor**: M message-passing layers with unshared weights and residual connections
  (Sec. 2, "Processor"): ``e'_sr = e_sr + phi_e(e_sr, v_s, v_r)``,
  ``v'_r = v_r + phi_v(v_r, sum_s phi_e(...))``. The first layer of phi_e is evaluated as
  ``W_e e + (W_s v)[s] + (W_r v)[r]``, identical to a linear layer on the concatenation but with
  the node terms computed once per node instead of once per edge.
* **Decoder**: an MLP to the normalised acceleration (no LayerNorm on its output).
* **Update** (Sec. 2, "Updater"): semi-implicit Euler with the frame as the time unit,
  ``v[t+1] = v[t] + a``, ``x[t+1] = x[t] + v[t+1]`` (:func:`integrate`).

Every MLP has ``mlp_layers`` hidden layers of width L with ReLU, and LayerNorm on its output
except the decoder's (paper: 2 hidden layers, L = 128, M = 10; see :class:`GNSConfig` for the
CPU-sized defaults and why).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import torch
from torch import nn

from sphkit.learn.data import NUM_TYPES, Normalizer, is_fluid
from sphkit.learn.graph import displacement, radius_graph


@dataclass
class GNSConfig:
    """Sizes of the network. The paper and LagrangeBench use latent 128 and 10 message-passing
    layers; on two CPU cores in ten minutes a smaller network trains more steps and reaches a
    lower error (README, "Learned simulators", has the measurements)."""

    dim: int = 2
    latent: int = 32
    layers: int = 3  #: message-passing layers M
    mlp_layers: int = 2  #: hidden layers per MLP
    velocities: int = 5  #: C, the velocity history (input_seq_length - 1)
    type_embedding: int = 16
    #: how the velocity history enters the node features: "velocities" (the paper: C
    #: normalised velocities) or "differences" (the last velocity normalised with the velocity
    #: statistics and the C - 1 frame accelerations ``v[t-k] - v[t-k-1]`` with the acceleration
    #: statistics: the same information, an invertible linear map of it, but the acceleration
    #: the network must mostly continue is no longer a difference of two nearly equal inputs;
    #: on the 2D dam break at 100 frames/s the velocity statistics are 7 to 13 times the
    #: acceleration's, and the paper's form learned about half as fast, see README)
    history: str = "differences"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def mlp(n_in: int, width: int, n_out: int, hidden: int, layer_norm: bool) -> nn.Sequential:
    """``hidden`` ReLU layers of ``width``, a linear output, optional LayerNorm on it."""
    mods: list[nn.Module] = []
    d = n_in
    for _ in range(hidden):
        mods += [nn.Linear(d, width), nn.ReLU()]
        d = width
    mods.append(nn.Linear(d, n_out))
    if layer_norm:
        mods.append(nn.LayerNorm(n_out))
    return nn.Sequential(*mods)


class _EdgeMLP(nn.Module):
    """phi_e on (e, v_s, v_r) with its first layer split (see the module notes)."""

    def __init__(self, latent: int, hidden: int) -> None:
        super().__init__()
        self.we = nn.Linear(latent, latent)
        self.ws = nn.Linear(latent, latent, bias=False)
        self.wr = nn.Linear(latent, latent, bias=False)
        self.rest = mlp(latent, latent, latent, hidden - 1, layer_norm=True)

    def forward(self, e: torch.Tensor, v: torch.Tensor, s: torch.Tensor,
                r: torch.Tensor) -> torch.Tensor:
        h = self.we(e) + self.ws(v)[s] + self.wr(v)[r]
        return self.rest(torch.relu(h))


class InteractionLayer(nn.Module):
    """One message-passing layer with residual connections."""

    def __init__(self, latent: int, hidden: int) -> None:
        super().__init__()
        self.edge = _EdgeMLP(latent, hidden)
        self.node = mlp(2 * latent, latent, latent, hidden, layer_norm=True)

    def forward(self, v: torch.Tensor, e: torch.Tensor, s: torch.Tensor,
                r: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        m = self.edge(e, v, s, r)
        agg = torch.zeros_like(v).index_add_(0, r, m)
        return v + self.node(torch.cat([v, agg], dim=1)), e + m


class GNS(nn.Module):
    """The encode-process-decode network: features -> normalised acceleration per node."""

    def __init__(self, config: GNSConfig) -> None:
        super().__init__()
        self.config = config
        c, L = config, config.latent
        n_node = c.velocities * c.dim + 2 * c.dim + c.type_embedding
        self.embed = nn.Embedding(NUM_TYPES, c.type_embedding)
        self.node_encoder = mlp(n_node, L, L, c.mlp_layers, layer_norm=True)
        self.edge_encoder = mlp(c.dim + 1, L, L, c.mlp_layers, layer_norm=True)
        self.processor = nn.ModuleList(InteractionLayer(L, c.mlp_layers) for _ in range(c.layers))
        self.decoder = mlp(L, L, c.dim, c.mlp_layers, layer_norm=False)

    def forward(self, node_features: torch.Tensor, particle_type: torch.Tensor,
                edge_features: torch.Tensor, senders: torch.Tensor,
                receivers: torch.Tensor) -> torch.Tensor:
        v = self.node_encoder(torch.cat([node_features, self.embed(particle_type)], dim=1))
        e = self.edge_encoder(edge_features)
        for layer in self.processor:
            v, e = layer(v, e, senders, receivers)
        return self.decoder(v)


@dataclass
class Features:
    """Inputs of :class:`GNS` for one (batched) graph."""

    node: torch.Tensor
    particle_type: torch.Tensor
    edge: torch.Tensor
    senders: torch.Tensor
    receivers: torch.Tensor


class FeatureBuilder:
    """Graph and features from position histories, per the paper (module notes).

    ``bounds`` ([lo, hi] per axis), ``radius`` R [m], ``periodic`` per axis, statistics in
    ``normalizer`` (frame differences)."""

    def __init__(self, normalizer: Normalizer, bounds: Sequence[Sequence[float]], radius: float,
                 periodic: Sequence[bool] | None = None, history: str = "differences") -> None:
        if history not in ("velocities", "differences"):
            raise ValueError(f"history: {history!r}; expected 'velocities' or 'differences'")
        self.history = history
        self.normalizer = normalizer
        self.bounds = np.asarray(bounds, dtype=np.float64)
        self.radius = float(radius)
        self.periodic = list(periodic) if periodic is not None else None
        if self.periodic is not None and not any(self.periodic):
            self.periodic = None

    def velocities(self, history: np.ndarray) -> np.ndarray:
        """(N, W, dim) positions -> (N, W-1, dim) frame differences (minimum image)."""
        v = history[:, 1:] - history[:, :-1]
        if self.periodic is not None:
            for k, p in enumerate(self.periodic):
                if p:
                    L = self.bounds[k, 1] - self.bounds[k, 0]
                    v[..., k] -= L * np.round(v[..., k] / L)
        return v

    def __call__(self, histories: Sequence[np.ndarray], types: Sequence[np.ndarray],
                 device: torch.device | str = "cpu") -> Features:
        """Features of the batch of graphs: ``histories[g]`` (N_g, W, dim) float64 positions
        (W = C + 1), ``types[g]`` (N_g,)."""
        nodes, etypes, edges, ss, rs = [], [], [], [], []
        offset = 0
        R = self.radius
        for x, pt in zip(histories, types, strict=True):
            cur = x[:, -1]
            v = self.velocities(x)
            if self.history == "velocities":
                vel = self.normalizer.norm_vel(v)
            else:
                vel = np.concatenate([self.normalizer.norm_vel(v[:, -1:]),
                                      self.normalizer.norm_acc(v[:, 1:] - v[:, :-1])], axis=1)
            lo = np.clip((cur - self.bounds[:, 0]) / R, -1.0, 1.0)
            hi = np.clip((self.bounds[:, 1] - cur) / R, -1.0, 1.0)
            if self.periodic is not None:  # no walls along a periodic axis
                for k, p in enumerate(self.periodic):
                    if p:
                        lo[:, k] = hi[:, k] = 1.0
            nodes.append(np.concatenate([vel.reshape(len(x), -1), lo, hi], axis=1))
            s, r = radius_graph(cur, R, is_fluid(pt), self.periodic, self.bounds)
            d = displacement(cur, s, r, self.periodic, self.bounds) / R
            edges.append(np.concatenate([d, np.linalg.norm(d, axis=1, keepdims=True)], axis=1))
            ss.append(s + offset)
            rs.append(r + offset)
            etypes.append(pt)
            offset += len(x)

        def t(a: list[np.ndarray], dtype: torch.dtype) -> torch.Tensor:
            return torch.as_tensor(np.concatenate(a), dtype=dtype, device=device)

        return Features(t(nodes, torch.float32), t(etypes, torch.long), t(edges, torch.float32),
                        t(ss, torch.long), t(rs, torch.long))


def integrate(history: np.ndarray, acc: np.ndarray) -> np.ndarray:
    """Semi-implicit Euler in frame units: the next positions from the last two of ``history``
    (N, W, dim) and the (de-normalised) accelerations ``acc`` (N, dim)."""
    v = history[:, -1] - history[:, -2] + acc
    return history[:, -1] + v


class LearnedSimulator:
    """A trained GNS with its normalisation and graph settings: :meth:`step` advances one
    frame."""

    def __init__(self, model: GNS, features: FeatureBuilder,
                 device: torch.device | str = "cpu") -> None:
        self.model = model
        self.features = features
        self.device = device

    @torch.no_grad()
    def acceleration(self, history: np.ndarray, particle_type: np.ndarray) -> np.ndarray:
        """De-normalised accelerations (N, dim) [m/frame^2] for one history (N, W, dim)."""
        self.model.eval()
        f = self.features([history], [particle_type], self.device)
        out = self.model(f.node, f.particle_type, f.edge, f.senders, f.receivers)
        return self.features.normalizer.denorm_acc(out.double().cpu().numpy())

    def step(self, history: np.ndarray, particle_type: np.ndarray) -> np.ndarray:
        """The next positions (N, dim); non-fluid particles keep their last positions."""
        nxt = integrate(history, self.acceleration(history, particle_type))
        fixed = ~is_fluid(particle_type)
        nxt[fixed] = history[fixed, -1]
        return nxt

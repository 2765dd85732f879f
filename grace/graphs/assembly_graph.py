"""The Assembly Graph (paper Sec. IV-B, docs/assembly-graph.md) as a function of (Assembly, state).

Everything that does not depend on the state is computed once per assembly into
:class:`AssemblyTensors`; a state only sets the assembled flags. :func:`state_graph` builds the
per-state heterogeneous PyG graph the reference network consumes:
- part nodes `[assembled-flag, part-type, PE(part-id)]` (1 + 1 + 16 = 18 features; with
  `enc.cell`, beyond the paper, the cell's features of the part follow, grace.graphs.cell_features),
- surface nodes `[surface-type, PE(surface-id)]` (1 + 16 = 17 features),
- ("surface", "near", "surface"): the complete graph over surfaces including self loops, one edge
  feature (the relation: parallel distances divided by `distance_scale`, self loop 0),
- ("surface", "of", "part"): each surface to its own part, no feature,
- ("part", "pair", "part"): beyond the paper, every ordered pair of distinct parts with its
  relative geometry (grace.graphs.pair_geometry), read only by a network with
  `model.net.pair_geometry` > 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch

from grace.domain.assembly import Assembly, Surface
from grace.graphs.encoding import GraphEncoding, node_ids
from grace.graphs.pair_geometry import PART_TYPE_INDEX, pair_geometry

if TYPE_CHECKING:
    from torch_geometric.data import HeteroData

SURFACE_EDGE = ("surface", "near", "surface")
PART_EDGE = ("surface", "of", "part")
PAIR_EDGE = ("part", "pair", "part")


@dataclass(frozen=True)
class AssemblyTensors:
    """State-independent inputs of one assembly (float32 tensors, surface order of Assembly)."""

    part_static: torch.Tensor  # (N, 1 + pe_dim [+ cell]): part-type, PE(part-id), cell features
    surface_x: torch.Tensor  # (S, 1 + pe_dim): surface-type, PE(surface-id)
    relation: torch.Tensor  # (S, S): scaled relation, zero diagonal
    surface_part: torch.Tensor  # (S,) int64: owning part of every surface
    pair_geometry: torch.Tensor  # (N, N, G): [m, n] part m seen from part n, zero diagonal

    @property
    def n_parts(self) -> int:
        return self.part_static.shape[0]

    @property
    def n_surfaces(self) -> int:
        return self.surface_x.shape[0]

    def to(self, dtype: torch.dtype) -> AssemblyTensors:
        """The same inputs with every floating tensor in `dtype` (a network cast to float64
        scores in float64)."""
        if dtype == self.part_static.dtype:
            return self
        return AssemblyTensors(
            part_static=self.part_static.to(dtype),
            surface_x=self.surface_x.to(dtype),
            relation=self.relation.to(dtype),
            surface_part=self.surface_part,
            pair_geometry=self.pair_geometry.to(dtype),
        )


def scaled_relations(
    assembly: Assembly, distance_scale: float, surfaces: list[Surface] | None = None
) -> np.ndarray:
    """Relation matrix with parallel distances in units of `distance_scale` mm (codes kept)."""
    rel = np.asarray(assembly.relations, dtype=np.float64)
    surfaces = assembly.surfaces() if surfaces is None else surfaces
    part = np.array([s.part for s in surfaces])
    normals = np.array([s.normal for s in surfaces], dtype=np.float64)
    parallel = (part[:, None] != part[None, :]) & (np.abs(normals @ normals.T) > 0.5)
    out = np.where(parallel, rel / distance_scale, rel)
    np.fill_diagonal(out, 0.0)
    return out


def encode_assembly(
    assembly: Assembly,
    enc: GraphEncoding,
    training: bool = False,
    rng: np.random.Generator | None = None,
) -> AssemblyTensors:
    """Node features and edge relations of `assembly`; `rng` only for a randomised `enc`."""
    surfaces = assembly.surfaces()
    surface_part = np.array([s.part for s in surfaces], dtype=np.int64)
    surface_index = np.array([s.index for s in surfaces], dtype=np.int64)
    part_ids, surface_ids = node_ids(
        surface_part, surface_index, assembly.n_parts, enc, training, rng
    )
    part_type = np.array([[PART_TYPE_INDEX[p.type]] for p in assembly.parts], dtype=np.float64)
    surface_type = np.array([[int(s.type)] for s in surfaces], dtype=np.float64)
    relation = scaled_relations(assembly, enc.distance_scale, surfaces)
    part_static = np.hstack([part_type, enc.encode(part_ids, rng, enc.part_pe)])
    if enc.cell is not None:  # beyond the paper: what the cell decides (model.graph.cell)
        from grace.graphs.cell_features import cell_features

        part_static = np.hstack(
            [part_static, cell_features(assembly, enc.cell, enc.distance_scale)]
        )
    surface_x = np.hstack([surface_type, enc.encode(surface_ids, rng)])
    return AssemblyTensors(
        part_static=torch.as_tensor(part_static, dtype=torch.float32),
        surface_x=torch.as_tensor(surface_x, dtype=torch.float32),
        relation=torch.as_tensor(relation, dtype=torch.float32),
        surface_part=torch.as_tensor(surface_part),
        pair_geometry=torch.as_tensor(
            pair_geometry(assembly, enc.distance_scale), dtype=torch.float32
        ),
    )


def state_flags(
    states: np.ndarray | torch.Tensor, n_parts: int, dtype: torch.dtype = torch.float32
) -> torch.Tensor:
    """Assembled flags (len(states), n_parts) of state bitmasks, on the device of `states`, in
    `dtype` (the network's inputs'). Torch operations only, so a compiled planning query builds
    them in its graph."""
    states = torch.as_tensor(states, dtype=torch.int64).reshape(-1, 1)
    bits = torch.arange(n_parts, device=states.device)
    return ((states >> bits) & 1).to(dtype)


def state_graph(tensors: AssemblyTensors, state: int) -> HeteroData:
    """The Assembly Graph of `tensors` in `state`, as heterogeneous PyG data."""
    from torch_geometric.data import HeteroData  # the reference path only: planning never loads PyG

    n, s = tensors.n_parts, tensors.n_surfaces
    data = HeteroData()
    flags = state_flags(np.array([state]), n, tensors.part_static.dtype)[0]
    data["part"].x = torch.cat([flags[:, None], tensors.part_static], dim=1)
    data["surface"].x = tensors.surface_x
    src, dst = torch.meshgrid(torch.arange(s), torch.arange(s), indexing="xy")
    data[SURFACE_EDGE].edge_index = torch.stack([src.reshape(-1), dst.reshape(-1)])
    data[SURFACE_EDGE].edge_attr = tensors.relation.T.reshape(-1, 1)
    data[PART_EDGE].edge_index = torch.stack([torch.arange(s), tensors.surface_part])
    src, dst = torch.meshgrid(torch.arange(n), torch.arange(n), indexing="ij")
    other = src != dst
    data[PAIR_EDGE].edge_index = torch.stack([src[other], dst[other]])
    data[PAIR_EDGE].edge_attr = tensors.pair_geometry[other]
    return data


def assembly_graph(
    assembly: Assembly,
    state: int,
    enc: GraphEncoding | None = None,
    training: bool = False,
    rng: np.random.Generator | None = None,
) -> HeteroData:
    """Convenience: the Assembly Graph of `assembly` in `state` (bit i set = part i placed)."""
    return state_graph(encode_assembly(assembly, enc or GraphEncoding(), training, rng), state)

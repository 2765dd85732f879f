"""Padded per-assembly tensors: the input of the fast GRACE path (one row per assembly)."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from grace.graphs.assembly_graph import AssemblyTensors


@dataclass
class DenseAssemblies:
    """Padded state-independent tensors of A assemblies (S = max surfaces, N = max parts)."""

    surface_x: torch.Tensor  # (A, S, Fs)
    relation: torch.Tensor  # (A, S, S)
    surface_mask: torch.Tensor  # (A, S) bool
    surface_part: torch.Tensor  # (A, S) long, 0 on padding
    part_static: torch.Tensor  # (A, N, Fp - 1)
    part_mask: torch.Tensor  # (A, N) bool
    pair_geometry: torch.Tensor  # (A, N, N, G): [a, m, n] part m seen from part n
    ownership: torch.Tensor  # (A, N, S) 1 where surface s belongs to part n, 0 elsewhere

    @classmethod
    def stack(cls, items: list[AssemblyTensors]) -> DenseAssemblies:
        if len(items) == 1:  # nothing to pad: views of the tensors (a cold next-step query)
            t = items[0]
            s, n = t.n_surfaces, t.n_parts
            ownership = torch.zeros(1, n, s, dtype=t.surface_x.dtype)
            ownership[0, t.surface_part, torch.arange(s)] = 1.0
            return cls(
                surface_x=t.surface_x[None],
                relation=t.relation[None],
                surface_mask=torch.ones(1, s, dtype=torch.bool),
                surface_part=t.surface_part[None],
                part_static=t.part_static[None],
                part_mask=torch.ones(1, n, dtype=torch.bool),
                pair_geometry=t.pair_geometry[None],
                ownership=ownership,
            )
        a = len(items)
        s = max(t.n_surfaces for t in items)
        n = max(t.n_parts for t in items)
        dtype = items[0].surface_x.dtype
        out = cls(
            surface_x=torch.zeros(a, s, items[0].surface_x.shape[1], dtype=dtype),
            relation=torch.zeros(a, s, s, dtype=dtype),
            surface_mask=torch.zeros(a, s, dtype=torch.bool),
            surface_part=torch.zeros(a, s, dtype=torch.long),
            part_static=torch.zeros(a, n, items[0].part_static.shape[1], dtype=dtype),
            part_mask=torch.zeros(a, n, dtype=torch.bool),
            pair_geometry=torch.zeros(a, n, n, items[0].pair_geometry.shape[-1], dtype=dtype),
            ownership=torch.zeros(a, n, s, dtype=dtype),
        )
        for i, t in enumerate(items):
            ns, nn_ = t.n_surfaces, t.n_parts
            out.surface_x[i, :ns] = t.surface_x
            out.relation[i, :ns, :ns] = t.relation
            out.surface_mask[i, :ns] = True
            out.surface_part[i, :ns] = t.surface_part
            out.part_static[i, :nn_] = t.part_static
            out.part_mask[i, :nn_] = True
            out.pair_geometry[i, :nn_, :nn_] = t.pair_geometry
            out.ownership[i, t.surface_part, torch.arange(ns)] = 1.0
        return out

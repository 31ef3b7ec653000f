"""Recurrent building blocks: a masked LSTM encoder and a GRU decoder with hoisted inputs."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn


def run_masked_lstm(cell: nn.LSTMCell, inputs: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Run an LSTM cell over a left-padded sequence; return the state at the last step.

    The state stays zero over the leading masked steps, so every sequence starts from a zero
    state at its first observed step, exactly as packing variable-length sequences would.

    Args:
        cell: the LSTM cell.
        inputs: (B, T, D).
        mask: (B, T) True on observed steps; the last step must be observed.

    Returns:
        (B, hidden) hidden state after step T-1.
    """
    batch = inputs.shape[0]
    h = inputs.new_zeros(batch, cell.hidden_size)
    c = inputs.new_zeros(batch, cell.hidden_size)
    for step in range(inputs.shape[1]):  # 8 history steps; batched over B
        h_new, c_new = cell(inputs[:, step], (h, c))
        observed = mask[:, step, None]
        h = torch.where(observed, h_new, h)
        c = torch.where(observed, c_new, c)
    return h


class HoistedGRUDecoder(nn.Module):
    """A GRU cell whose input is ``[z; x; a_prev]``, with the ``[z; x]`` part projected once.

    The gates' input projection ``W_ih [z; x; a]`` splits into ``W_z z + W_x x + W_a a``. Only
    ``W_a a`` changes from step to step, ``W_x x`` is shared by all latent values of a sample and
    ``W_z z`` is a column of ``W_z`` (z is one-hot), so the recurrence only multiplies the 2-d
    action and the hidden state. The weights are those of an ``nn.GRUCell`` on the full input,
    so the mathematics is the plain GRU's.
    """

    def __init__(self, latent_values: int, condition_dim: int, action_dim: int, hidden: int):
        super().__init__()
        self.latent_values = latent_values
        self.condition_dim = condition_dim
        self.cell = nn.GRUCell(latent_values + condition_dim + action_dim, hidden)
        self.initial_h = nn.Linear(latent_values + condition_dim, hidden)

    @staticmethod
    def _latent_rows(w_z: torch.Tensor, z_index: torch.Tensor | None) -> torch.Tensor:
        """The columns of ``w_z`` picked by one-hot z: (1, Z, out) for all modes, else (B, M, out).

        With every mode decoded (training) this is a broadcast, not a gather, which keeps the
        backward pass a cheap sum instead of a scatter.
        """
        return w_z.T[None] if z_index is None else w_z.T[z_index]

    def input_gates(self, x: torch.Tensor, z_index: torch.Tensor | None) -> torch.Tensor:
        """(B, Dx) condition and (B, M) latent values (None: all Z) -> (B, M, 3*hidden)."""
        Z, Dx = self.latent_values, self.condition_dim
        w_x = self.cell.weight_ih[:, Z : Z + Dx]  # (3h, Dx)
        from_x = x @ w_x.T + self.cell.bias_ih  # (B, 3h)
        return from_x[:, None, :] + self._latent_rows(self.cell.weight_ih[:, :Z], z_index)

    def initial_state(self, x: torch.Tensor, z_index: torch.Tensor | None) -> torch.Tensor:
        """(B, M, hidden) h_0 = Linear([z; x]), M = Z when ``z_index`` is None."""
        Z = self.latent_values
        from_x = x @ self.initial_h.weight[:, Z:].T + self.initial_h.bias  # (B, h)
        return from_x[:, None, :] + self._latent_rows(self.initial_h.weight[:, :Z], z_index)

    def step(
        self,
        gates_zx: torch.Tensor,
        action: torch.Tensor,
        h: torch.Tensor,
        work: StepBuffers | None = None,
        out: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """One GRU step on rows: (R, 3h) constant gates, (R, A) previous action, (R, h) state
        -> the new (R, h) state. With ``work`` every intermediate is written into it and the
        new state into ``out`` (inference only: ``out=`` operations have no gradient); the
        operations are the same either way, so are the numbers."""
        hidden = self.cell.hidden_size
        w = work if work is not None else _ALLOCATE
        w_a = self.cell.weight_ih[:, self.latent_values + self.condition_dim :]  # (3h, A)
        gates_in = torch.addmm(gates_zx, action, w_a.T, out=w.gates_in)
        gates_h = torch.addmm(self.cell.bias_hh, h, self.cell.weight_hh.T, out=w.gates_h)
        # reset and update gates in one sigmoid: each operation's fixed cost counts at the
        # few hundred rows of a live update
        both = torch.add(gates_in[:, : 2 * hidden], gates_h[:, : 2 * hidden], out=w.reset_update)
        reset_update = torch.sigmoid(both, out=w.reset_update)
        reset, update = reset_update[:, :hidden], reset_update[:, hidden:]
        candidate = torch.addcmul(
            gates_in[:, 2 * hidden :], reset, gates_h[:, 2 * hidden :], out=w.candidate
        )
        candidate = torch.tanh(candidate, out=w.candidate)
        change = torch.mul(torch.sub(h, candidate, out=w.change), update, out=w.change)
        return torch.add(candidate, change, out=out)


@dataclass(frozen=True)
class StepBuffers:
    """Storage for the intermediates of :meth:`HoistedGRUDecoder.step` on R rows.

    A live update's decoder allocates about 5 MB of intermediates per step at 300 people, and
    fresh memory of that size comes from the operating system page by page: reusing these for
    every step took the decoder's steps from 7.5 to 6.5 ms there
    (``benchmarks/streaming.py --profile``).

    Attributes:
        gates_in, gates_h: (R, 3h) the input's and the state's gates.
        reset_update: (R, 2h) both sigmoid gates.
        candidate, change: (R, h) the candidate state and the update's share of the change.
        (None everywhere: the operations allocate their results.)
    """

    gates_in: torch.Tensor | None = None
    gates_h: torch.Tensor | None = None
    reset_update: torch.Tensor | None = None
    candidate: torch.Tensor | None = None
    change: torch.Tensor | None = None

    @classmethod
    def like(cls, gates_zx: torch.Tensor) -> StepBuffers:
        """Buffers for the rows of (R, 3h) ``gates_zx``, of its dtype and device."""
        rows, hidden = gates_zx.shape[0], gates_zx.shape[1] // 3
        # Row-major whatever the layout of ``gates_zx`` (one sample's rows are a column-major
        # view): a product written into a column-major buffer is summed in another order.
        return cls(
            gates_in=gates_zx.new_empty(gates_zx.shape),
            gates_h=gates_zx.new_empty(gates_zx.shape),
            reset_update=gates_zx.new_empty(rows, 2 * hidden),
            candidate=gates_zx.new_empty(rows, hidden),
            change=gates_zx.new_empty(rows, hidden),
        )


_ALLOCATE = StepBuffers()
"""No buffers: every operation of a step allocates its result (training, export)."""

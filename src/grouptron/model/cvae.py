"""The Trajectron++ conditional VAE for one pedestrian type, batched over samples.

Read top to bottom: encoders -> latent distributions -> decoder. ``forward`` is stateless: it
maps a :class:`Batch` to a :class:`CVAEOutput`; losses live in ``grouptron.model.elbo``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch
import torch.nn.functional as F
from torch import nn

from grouptron.config import ModelConfig
from grouptron.errors import GrouptronError
from grouptron.model import gaussians, noise, predict, schedules
from grouptron.model.batch import Batch
from grouptron.model.cvae_outputs import CVAEOutput, Encoding, Feedback, VelocityGaussians
from grouptron.model.elbo import LossTerms, elbo_loss
from grouptron.model.forecaster import Forecaster, TrainingStep
from grouptron.model.layers import HoistedGRUDecoder, StepBuffers, run_masked_lstm
from grouptron.model.noise import TrainingNoise
from grouptron.point_forecast import PointForecast

if TYPE_CHECKING:
    from grouptron.config import ExperimentConfig

__all__ = ["CVAEOutput", "Encoding", "TrajectronCVAE", "VelocityGaussians", "centre_logits"]


def centre_logits(logits: torch.Tensor, clip: float | None) -> torch.Tensor:
    """Subtract the mean logit and optionally clip to [-clip, clip] (the reference's scheme)."""
    centred = logits - logits.mean(dim=-1, keepdim=True)
    return centred.clamp(-clip, clip) if clip is not None else centred


class TrajectronCVAE(Forecaster):
    """History LSTM + edge LSTM -> discrete latent -> GRU decoder of velocity Gaussians.

    As a :class:`Forecaster`: trained on the negative ELBO with the reference's annealing,
    its point forecasts the mode (``ml``, of its most probable latent values for ``ml-topK``)
    or the mean of its Gaussian mixture over the latent values (``model.predict``).
    """

    point_forecasts = ("ml", "mean")

    def __init__(
        self, config: ModelConfig, extra_condition_dim: int = 0, velocity_scale_mps: float = 2.0
    ):
        super().__init__()
        self.config = config
        self.velocity_scale_mps = velocity_scale_mps  # standardised -> m/s (the residual)
        c = config
        self.history_encoder = nn.LSTMCell(c.state_dim, c.history_hidden)
        edge_input_dim = 2 * c.state_dim + int(c.edge_count_feature)
        self.edge_encoder = nn.LSTMCell(edge_input_dim, c.edge_hidden) if c.use_edges else None
        self.condition_dim = c.history_hidden + (c.edge_hidden if c.use_edges else 0)
        self.base_condition_dim = self.condition_dim  # Trajectron++'s [edge; history]
        self.condition_dim += extra_condition_dim
        self.future_encoder = nn.LSTM(
            c.action_dim, c.future_hidden, batch_first=True, bidirectional=True
        )
        self.future_initial_h = nn.Linear(c.state_dim, c.future_hidden)
        self.future_initial_c = nn.Linear(c.state_dim, c.future_hidden)
        future_dim = 4 * c.future_hidden  # [h_fwd; h_bwd; c_fwd; c_bwd]
        self.p_z_hidden = nn.Linear(self.condition_dim, c.p_z_hidden)
        self.p_z_logits = nn.Linear(c.p_z_hidden, c.latent_values)
        self.q_z_logits = nn.Linear(self.condition_dim + future_dim, c.latent_values)
        self.decoder = HoistedGRUDecoder(
            c.latent_values, self.condition_dim, c.action_dim, c.decoder_hidden
        )
        self.initial_action = nn.Linear(c.state_dim, c.action_dim)
        self.gaussian_head = nn.Linear(c.decoder_hidden, 5)  # mu (2), log sigma (2), corr (1)

    def extra_dropout_sizes(self) -> dict[str, int]:
        """Dropout sites beyond the CVAE's (``noise.dropout_sizes``), drawn after them."""
        return {}

    @property
    def latent_values(self) -> int:
        """Z, the values of the discrete latent."""
        return self.config.latent_values

    @property
    def ablations(self) -> tuple[str, ...]:
        """``edges`` where it reads its neighbours (Grouptron adds ``scene``)."""
        return ("edges",) if self.config.use_edges else ()

    # --- the forecaster interface -----------------------------------------------------------

    def training_noise(self, rows: int, config: ExperimentConfig) -> TrainingNoise:
        """Dropout masks and decoder draws of the whole global batch (``model.noise``)."""
        sizes = self.extra_dropout_sizes()
        return noise.draw_training_noise(rows, config.model, config.data.horizon_steps, sizes)

    def training_loss(self, batch: Batch, step: TrainingStep) -> LossTerms:
        """The negative ELBO at the step's KL weight and logit clip (``model.schedules``)."""
        c = step.config
        clip = schedules.logit_clip(c.loss, step.iteration)
        output = self(batch, step.noise, logit_clip=clip, bf16=c.train.bf16)
        weight = schedules.kl_weight(c.loss, step.iteration)
        return elbo_loss(
            output, batch, c.loss, weight, dt_s=c.data.dt_s, batch_mean=step.batch_mean
        )

    def sample(
        self,
        batch: Batch,
        horizon: int,
        dt_s: float,
        num_samples: int,
        generator: torch.Generator | None = None,
    ) -> torch.Tensor:
        """(B, K, H, 2) futures: z ~ p(z|x), a velocity drawn and fed back per step."""
        return self.forecast_futures(
            batch, horizon, dt_s, num_samples=num_samples, generator=generator
        )

    def point(
        self, batch: Batch, forecast: PointForecast, horizon: int, dt_s: float
    ) -> predict.Decoded:
        """The point forecast ``forecast`` with the Gaussians it was made from."""
        return self.forecast_point(batch, forecast, horizon, dt_s)

    def forecast_point(
        self,
        batch: Batch,
        forecast: PointForecast,
        horizon: int,
        dt_s: float,
        *,
        every: bool = False,
        ablate: tuple[str, ...] = (),
    ) -> predict.Decoded:
        """``model.predict.decode``: only the latent values ``forecast`` reads (all Z with
        ``every``), with ``ablate``'s inputs zeroed."""
        return predict.decode(self, batch, forecast, horizon, dt_s, every=every, ablate=ablate)

    def forecast_futures(
        self,
        batch: Batch,
        horizon: int,
        dt_s: float,
        *,
        num_samples: int,
        generator: torch.Generator | None = None,
        ablate: tuple[str, ...] = (),
    ) -> torch.Tensor:
        """``model.predict.predict_samples`` with ``ablate``'s inputs zeroed."""
        return predict.predict_samples(
            self, batch, horizon, dt_s, num_samples=num_samples, generator=generator, ablate=ablate
        )

    # --- encoders ---------------------------------------------------------------------------

    def _dropout(
        self, h: torch.Tensor, drawn: TrainingNoise | None, site: str, keep: float
    ) -> torch.Tensor:
        uniforms = drawn.dropout.get(site) if drawn is not None else None
        return noise.dropout(h, keep, self.training, uniforms)

    def encode_condition(self, batch: Batch, drawn: TrainingNoise | None = None) -> torch.Tensor:
        """(B, Dx) ``x = [edge encoding; history encoding]`` (Grouptron appends its own);
        ``drawn``: a training step's dropout masks (None: the global RNG)."""
        keep = self.config.rnn_dropout_keep
        history = self._dropout(
            run_masked_lstm(self.history_encoder, batch.hist_st, batch.hist_mask),
            drawn,
            "history",
            keep,
        )
        if self.edge_encoder is None:
            return history
        edge = run_masked_lstm(self.edge_encoder, self._edge_input(batch), batch.hist_mask)
        edge = self._dropout(edge, drawn, "edge", keep)
        edge = edge * batch.edge_scale[:, None]
        # The reference combines edge types by attention and applies dropout again; with the
        # single pedestrian-pedestrian edge type the attention is the identity.
        edge = self._dropout(edge, drawn, "edge_combined", keep)
        return torch.cat([edge, history], dim=-1)

    def _edge_input(self, batch: Batch) -> torch.Tensor:
        """(B, T, 12) ``[neighbours; ego]`` (13 with the count feature)."""
        c = self.config
        if c.edge_aggregation == "sum" and not c.edge_count_feature:
            return torch.cat([batch.nbr_sum_st, batch.hist_st], dim=-1)
        if batch.nbr_count is None:
            raise GrouptronError("this model needs batches with nbr_count (make_batch)")
        count = batch.nbr_count[..., None]  # (B, T, 1)
        neighbours = batch.nbr_sum_st
        if c.edge_aggregation == "mean":
            neighbours = neighbours / count.clamp(min=1.0)
        parts = [neighbours, batch.hist_st]
        return torch.cat([*parts, torch.log1p(count)] if c.edge_count_feature else parts, -1)

    def encode_future(self, batch: Batch, drawn: TrainingNoise | None = None) -> torch.Tensor:
        """(B, 4*future_hidden) final states of the bi-LSTM over the standardised future."""
        now = batch.state_now_st
        h_fwd, c_fwd = self.future_initial_h(now), self.future_initial_c(now)
        # Forward direction starts from the current state; the backward one from zeros.
        h0 = torch.stack([h_fwd, torch.zeros_like(h_fwd)])
        c0 = torch.stack([c_fwd, torch.zeros_like(c_fwd)])
        _, (h_n, c_n) = self.future_encoder(batch.fut_st, (h0, c0))  # (2, B, hf) each
        state = torch.cat([h_n, c_n], dim=0).permute(1, 0, 2).reshape(len(batch), -1)
        return self._dropout(state, drawn, "future", self.config.rnn_dropout_keep)

    def encode(
        self,
        batch: Batch,
        x: torch.Tensor,
        *,
        with_future: bool,
        logit_clip: float | None,
        drawn: TrainingNoise | None = None,
    ) -> Encoding:
        """Latent logits from the condition (and the future, for the posterior)."""
        hidden = F.relu(self.p_z_hidden(x))
        hidden = self._dropout(hidden, drawn, "p_z", self.config.mlp_dropout_keep)
        p_logits = centre_logits(self.p_z_logits(hidden), logit_clip)
        q_logits = None
        if with_future:
            q_input = torch.cat([x, self.encode_future(batch, drawn)], dim=-1)
            q_logits = centre_logits(self.q_z_logits(q_input), logit_clip)
        return Encoding(x=x, p_logits=p_logits, q_logits=q_logits)

    # --- decoder ----------------------------------------------------------------------------

    def decode(
        self,
        x: torch.Tensor,
        state_now_st: torch.Tensor,
        z_index: torch.Tensor | None,
        horizon: int,
        *,
        feedback: Feedback,
        generator: torch.Generator | None = None,
        draws: torch.Tensor | None = None,
    ) -> VelocityGaussians:
        """Decode ``M`` latent values per sample into per-step velocity Gaussians.

        Args:
            x: (B, Dx) condition.
            state_now_st: (B, 6) current standardised state (for the initial action).
            z_index: (B, M) latent values to decode; None decodes all Z values (M = Z).
            horizon: H steps.
            feedback: feed back a Gaussian ``"sample"`` (training, sampling) or its ``"mean"``.
            generator: RNG for the samples (None: the global one).
            draws: (B, M, H, 2) standard normal draws for the samples instead of the RNG.
        """
        c = self.config
        B = x.shape[0]
        M = c.latent_values if z_index is None else z_index.shape[1]
        gates_zx = self.decoder.input_gates(x, z_index).reshape(B * M, -1)  # (B*M, 3h)
        h = self.decoder.initial_state(x, z_index).reshape(B * M, -1)  # (B*M, h)
        action = self.initial_action(state_now_st)[:, None, :].expand(B, M, -1).reshape(B * M, -1)
        offset: torch.Tensor | float = 0.0  # velocity_residual: means relative to now
        if c.velocity_residual:
            now_mps = state_now_st[:, 2:4].float() * self.velocity_scale_mps  # (B, 2)
            offset = now_mps[:, None, :].expand(B, M, -1).reshape(B * M, 2)
        if feedback == "mean":
            return self._decode_means(gates_zx, h, action, offset, (B, M, horizon))
        means, log_sigmas, corrs, fed = [], [], [], []
        for k in range(horizon):  # the recurrence; batched over B*M rows
            h = self.decoder.step(gates_zx, action, h)
            head = self.gaussian_head(h).float()  # (B*M, 5)
            mean = head[:, :2] + offset
            log_sigma = head[:, 2:4].clamp(c.log_sigma_min, c.log_sigma_max)
            corr = torch.tanh(head[:, 4]).clamp(-c.corr_max, c.corr_max)
            if feedback == "sample":
                eps = None if draws is None else draws[:, :, k].reshape(B * M, 2)
                action = gaussians.sample(mean, log_sigma, corr, generator, eps=eps)
            else:
                action = mean
            means.append(mean)
            log_sigmas.append(log_sigma)
            corrs.append(corr)
            fed.append(action)
        return VelocityGaussians(
            mean=torch.stack(means, 1).reshape(B, M, horizon, 2),
            log_sigma=torch.stack(log_sigmas, 1).reshape(B, M, horizon, 2),
            corr=torch.stack(corrs, 1).reshape(B, M, horizon),
            fed_back=torch.stack(fed, 1).reshape(B, M, horizon, 2),
        )

    def _decode_means(
        self,
        gates_zx: torch.Tensor,
        h: torch.Tensor,
        action: torch.Tensor,
        offset: torch.Tensor | float,
        shape: tuple[int, int, int],
    ) -> VelocityGaussians:
        """The recurrence fed its own means: (R, 3h) gates, (R, h) state, (R, A) first action
        and (R, 2) or 0 offset for R = B*M rows -> Gaussians shaped (B, M, H, ...).

        Only the means feed the next step, so the loop computes the head's two mean rows and
        the spreads come from all steps' states at once afterwards (the same affine map).
        Without gradients the steps reuse preallocated storage (:class:`StepBuffers`)."""
        c = self.config
        weight, bias = self.gaussian_head.weight, self.gaussian_head.bias  # (5, h), (5,)
        horizon = shape[2]
        reuse = not torch.is_grad_enabled() and not torch.compiler.is_exporting()
        work = StepBuffers.like(gates_zx) if reuse else None
        buffered = h.new_empty(horizon, *h.shape) if reuse else None  # (H, R, h) the states
        states, means = [], []
        for k in range(horizon):  # the recurrence; batched over B*M rows
            out = None if buffered is None else buffered[k]
            h = self.decoder.step(gates_zx, action, h, work, out=out)
            action = torch.addmm(bias[:2], h, weight[:2].T).float() + offset  # (R, 2)
            states.append(h)
            means.append(action)
        every_state = torch.stack(states) if buffered is None else buffered  # (H, R, h)
        spread = F.linear(every_state, weight[2:], bias[2:]).float()  # (H, R, 3)
        spread = spread.transpose(0, 1).contiguous()  # (R, H, 3)
        mean = torch.stack(means, 1).reshape(*shape, 2)
        return VelocityGaussians(
            mean=mean,
            log_sigma=spread[..., :2].clamp(c.log_sigma_min, c.log_sigma_max).reshape(*shape, 2),
            corr=torch.tanh(spread[..., 2]).clamp(-c.corr_max, c.corr_max).reshape(shape),
            fed_back=mean,
        )

    def forward(
        self,
        batch: Batch,
        drawn: TrainingNoise | None = None,
        logit_clip: float | None = None,
        bf16: bool = False,
    ) -> CVAEOutput:
        """Training pass: encode with the posterior and decode all Z latent values.

        Args:
            batch: the samples.
            drawn: the step's dropout masks and decoder draws (None: the global RNG).
            logit_clip: current logit clip of the annealing schedule (None: no clipping).
            bf16: run the decoder recurrence under bfloat16 autocast.
        """
        condition = self.encode_condition(batch, drawn)  # Grouptron appends E_scene
        encoding = self.encode(
            batch, condition, with_future=True, logit_clip=logit_clip, drawn=drawn
        )
        with torch.autocast(condition.device.type, dtype=torch.bfloat16, enabled=bf16):
            velocity = self.decode(
                condition,
                batch.state_now_st,
                None,
                batch.fut_st.shape[1],
                feedback="sample",
                draws=None if drawn is None else drawn.decoder,
            )
        return CVAEOutput(encoding=encoding, velocity=velocity)

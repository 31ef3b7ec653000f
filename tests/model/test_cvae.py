"""The CVAE's shapes, masks, hoisted decoder and latent handling."""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.layers import HoistedGRUDecoder
from tests.helpers.models import SMALL, random_batch


def test_forward_shapes() -> None:
    torch.manual_seed(0)
    model = TrajectronCVAE(SMALL)
    batch = random_batch()
    out = model(batch, logit_clip=1.0)
    assert out.encoding.x.shape == (6, 16)
    assert out.encoding.p_logits.shape == out.encoding.q_logits.shape == (6, 5)
    assert out.velocity.mean.shape == (6, 5, 12, 2)
    assert out.velocity.log_sigma.shape == (6, 5, 12, 2)
    assert out.velocity.corr.shape == (6, 5, 12)
    assert out.encoding.p_logits.abs().max() <= 1.0 + 1e-6  # clipped
    torch.testing.assert_close(out.encoding.p_logits.mean(-1), torch.zeros(6), atol=1e-6, rtol=0)


def test_masked_history_steps_do_not_matter() -> None:
    torch.manual_seed(0)
    model = TrajectronCVAE(SMALL).eval()
    batch = random_batch()
    garbage = batch.hist_st.clone()
    garbage[0, :5] = 1e3  # values under the mask
    nbr_garbage = batch.nbr_sum_st.clone()
    nbr_garbage[0, :5] = -1e3
    changed = dataclasses.replace(batch, hist_st=garbage, nbr_sum_st=nbr_garbage)
    torch.testing.assert_close(model.encode_condition(batch), model.encode_condition(changed))


def test_edge_encoding_scales_with_edge_weight_and_can_be_switched_off() -> None:
    torch.manual_seed(0)
    model = TrajectronCVAE(SMALL).eval()
    batch = random_batch()
    no_edges = dataclasses.replace(batch, edge_scale=torch.zeros(6))
    assert (model.encode_condition(no_edges)[:, :8] == 0).all()
    without = TrajectronCVAE(dataclasses.replace(SMALL, use_edges=False))
    assert without.encode_condition(batch).shape == (6, 8)


def test_hoisted_decoder_equals_a_plain_gru_cell() -> None:
    torch.manual_seed(0)
    decoder = HoistedGRUDecoder(latent_values=5, condition_dim=7, action_dim=2, hidden=16)
    x = torch.randn(3, 7)
    z_index = torch.tensor([[0, 4], [2, 2], [1, 3]])
    action = torch.randn(3, 2, 2)
    h = torch.randn(3, 2, 16)
    one_hot = torch.nn.functional.one_hot(z_index, 5).float()
    full_input = torch.cat([one_hot, x[:, None].expand(-1, 2, -1), action], -1)
    expected = decoder.cell(full_input.reshape(6, -1), h.reshape(6, -1))
    gates = decoder.input_gates(x, z_index).reshape(6, -1)
    got = decoder.step(gates, action.reshape(6, -1), h.reshape(6, -1))
    torch.testing.assert_close(got, expected)
    h0 = decoder.initial_h(torch.cat([one_hot, x[:, None].expand(-1, 2, -1)], -1))
    torch.testing.assert_close(decoder.initial_state(x, z_index), h0)
    all_gates = decoder.input_gates(x, None)
    torch.testing.assert_close(all_gates[:, [0, 4]][0], decoder.input_gates(x, z_index)[0])


def test_decoding_chosen_latents_equals_the_same_rows_of_all() -> None:
    torch.manual_seed(0)
    model = TrajectronCVAE(SMALL).eval()
    batch = random_batch()
    x = model.encode_condition(batch)
    every = model.decode(x, batch.state_now_st, None, 12, feedback="mean")
    chosen = torch.tensor(np.array([[3, 1]] * 6))
    some = model.decode(x, batch.state_now_st, chosen, 12, feedback="mean")
    torch.testing.assert_close(some.mean, every.mean[:, [3, 1]])
    torch.testing.assert_close(some.corr, every.corr[:, [3, 1]])


def test_sampled_feedback_is_reproducible_with_a_generator() -> None:
    torch.manual_seed(0)
    model = TrajectronCVAE(SMALL).eval()
    batch = random_batch()
    x = model.encode_condition(batch)
    z = torch.zeros(6, 4, dtype=torch.long)
    first = model.decode(
        x, batch.state_now_st, z, 12, feedback="sample", generator=torch.Generator().manual_seed(1)
    )
    again = model.decode(
        x, batch.state_now_st, z, 12, feedback="sample", generator=torch.Generator().manual_seed(1)
    )
    torch.testing.assert_close(first.fed_back, again.fed_back)
    assert not torch.allclose(first.fed_back[:, 0], first.fed_back[:, 1])


def test_following_the_means_equals_sampled_feedback_with_zero_draws() -> None:
    """The inference loop (means only per step, spreads afterwards) is the training loop's
    mathematics: fed zero draws, a sample is its mean."""
    torch.manual_seed(0)
    for residual in (False, True):
        model = TrajectronCVAE(dataclasses.replace(SMALL, velocity_residual=residual)).eval()
        batch = random_batch()
        x = model.encode_condition(batch)
        means = model.decode(x, batch.state_now_st, None, 12, feedback="mean")
        zero = torch.zeros(6, SMALL.latent_values, 12, 2)
        sampled = model.decode(x, batch.state_now_st, None, 12, feedback="sample", draws=zero)
        for name in ("mean", "log_sigma", "corr", "fed_back"):
            torch.testing.assert_close(getattr(means, name), getattr(sampled, name))


def test_inference_decoding_reuses_storage_with_the_same_numbers() -> None:
    """Without gradients the decoder's steps write into storage made once per call; the
    Gaussians are bitwise those of the allocating path (which training and export use), for one
    sample (whose rows are a column-major view) and several, every latent value or chosen
    ones, and come out contiguous."""
    torch.manual_seed(0)
    model = TrajectronCVAE(dataclasses.replace(SMALL, velocity_residual=True)).eval()
    batch = random_batch()
    for rows in (slice(0, 1), slice(0, 6)):
        x, now = model.encode_condition(batch)[rows].detach(), batch.state_now_st[rows]
        chosen = torch.tensor([[3, 1]]).expand(len(x), 2)
        for z_index in (None, chosen):
            allocating = model.decode(x, now, z_index, 12, feedback="mean")
            with torch.no_grad():
                reusing = model.decode(x, now, z_index, 12, feedback="mean")
            for name in ("mean", "log_sigma", "corr", "fed_back"):
                value = getattr(reusing, name)
                assert torch.equal(value, getattr(allocating, name)), (rows, name)
                assert value.is_contiguous(), (rows, name)

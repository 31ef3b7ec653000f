"""The ST-GCN block's temporal convolution."""

from __future__ import annotations

import pytest
import torch

from grouptron.model.stgcn import temporal_conv


@pytest.mark.parametrize(("kernel", "dilation"), [(3, 1), (3, 2), (3, 4), (3, 8), (5, 1)])
def test_the_temporal_convolution_equals_conv1d(kernel: int, dilation: int) -> None:
    """Dilations 1, 2 and 4 are the shipped blocks'; 8 puts both outer taps beyond the 8 steps,
    where only padding lies."""
    torch.manual_seed(0)
    pad = dilation * (kernel // 2)
    conv = torch.nn.Conv1d(5, 7, kernel, padding=pad, dilation=dilation)
    x = torch.randn(11, 8, 5)  # (N, T, D)
    expected = conv(x.transpose(1, 2)).transpose(1, 2)
    torch.testing.assert_close(temporal_conv(conv, x), expected, rtol=1e-5, atol=1e-6)
    x.requires_grad_(True)
    weights = torch.randn_like(expected)  # a loss that weighs every output differently
    ours = torch.autograd.grad((temporal_conv(conv, x) * weights).sum(), [x, *conv.parameters()])
    theirs = torch.autograd.grad(
        (conv(x.transpose(1, 2)).transpose(1, 2) * weights).sum(), [x, *conv.parameters()]
    )
    for mine, reference in zip(ours, theirs, strict=True):  # input, weight and bias
        torch.testing.assert_close(mine, reference, rtol=1e-5, atol=1e-5)


def test_a_temporal_convolution_without_bias_equals_conv1d() -> None:
    torch.manual_seed(0)
    conv = torch.nn.Conv1d(5, 7, 3, padding=2, dilation=2, bias=False)
    x = torch.randn(11, 8, 5)
    expected = conv(x.transpose(1, 2)).transpose(1, 2)
    torch.testing.assert_close(temporal_conv(conv, x), expected, rtol=1e-5, atol=1e-6)

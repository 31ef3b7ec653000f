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
    temporal_conv(conv, x).sum().backward()
    x_ref = x.detach().clone().requires_grad_(True)
    conv(x_ref.transpose(1, 2)).sum().backward()
    assert x.grad is not None and x_ref.grad is not None
    torch.testing.assert_close(x.grad, x_ref.grad, rtol=1e-5, atol=1e-6)

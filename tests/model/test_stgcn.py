"""The ST-GCN block's temporal convolution."""

from __future__ import annotations

import torch

from grouptron.model.stgcn import temporal_conv


def test_the_temporal_convolution_equals_conv1d() -> None:
    torch.manual_seed(0)
    conv = torch.nn.Conv1d(5, 7, 3, padding=1)
    x = torch.randn(11, 8, 5)  # (N, T, D)
    expected = conv(x.transpose(1, 2)).transpose(1, 2)
    torch.testing.assert_close(temporal_conv(conv, x), expected, rtol=1e-5, atol=1e-6)
    x.requires_grad_(True)
    temporal_conv(conv, x).sum().backward()
    assert x.grad is not None and torch.isfinite(x.grad).all()

"""``grouptron export``: the network as an ONNX file for running outside Python."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from grouptron.inference.calibration import calibration_for
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.inference.export import (
    ForecastNetwork,
    batch_inputs,
    example_batch,
    export_onnx,
    run_onnx,
)
from grouptron.io import refuse_folder
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import cvae_only
from grouptron.model.predict import default_point_forecast


def cmd_export(args: argparse.Namespace) -> int:
    """``grouptron export``: write a checkpoint's network as ONNX, then (unless
    ``--no-check``) compare onnxruntime's outputs with PyTorch's on an example batch."""
    out = Path(args.out)
    refuse_folder(out)  # before the work, not after it
    torch.set_num_threads(args.threads)
    path = resolve_checkpoint(args.checkpoint)
    loaded, config = load_trained_model(path)
    model = cvae_only(loaded, "ONNX export")  # the network a graph is traced from
    # The file states the default point forecast; a calibration of another would not fit.
    forecast = default_point_forecast(config)
    calibration = calibration_for(args.calibration, config, forecast, str(path))
    print(f"exporting {config.model_name} from {path} to ONNX (about half a minute)", flush=True)
    names = export_onnx(model, config, out, calibration)
    print(f"wrote {out}: {config.model_name} from {path}, inputs {', '.join(names)}")
    if args.no_check:
        return 0
    print("checking the file with onnxruntime against PyTorch", flush=True)
    network = ForecastNetwork(model, config)
    inputs = batch_inputs(example_batch(config), config)
    with torch.inference_mode():
        expected = [o.numpy() for o in network(*inputs)]
    got = run_onnx(out, {n: t.numpy() for n, t in zip(names, inputs, strict=True)})
    worst = max(float(np.abs(a - b).max()) for a, b in zip(expected, got, strict=True))
    print(f"onnxruntime agrees with PyTorch on an example batch: largest difference {worst:.1e}")
    return 0

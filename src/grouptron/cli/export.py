"""``grouptron export``: the network as an ONNX file for running outside Python."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from grouptron.cli.common import Formatter, add_threads_option
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.inference.export import (
    EXPORT_FORMATS,
    ForecastNetwork,
    batch_inputs,
    example_batch,
    export_onnx,
    run_onnx,
)
from grouptron.io import refuse_folder
from grouptron.model.checkpoint import load_trained_model


def cmd_export(args: argparse.Namespace) -> int:
    out = Path(args.out)
    refuse_folder(out)  # before the work, not after it
    torch.set_num_threads(args.threads)
    path = resolve_checkpoint(args.checkpoint)
    model, config = load_trained_model(path)
    print(f"exporting {config.model_name} from {path} to ONNX (about half a minute)", flush=True)
    names = export_onnx(model, config, out)
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


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    export = commands.add_parser(
        "export",
        help="write a checkpoint's network as ONNX (for C++, a robot, another runtime)",
        description="Write the network of a checkpoint, from standardised inputs to the "
        "forecast distribution (log p(z|x), each latent value's mean positions and "
        "covariances), as an ONNX file with dynamic sample, node and group counts. What the "
        "caller computes before (standardised histories, neighbour sums, groups) and after "
        "(most likely forecast, samples) is in docs/export.md; the constants it needs are in "
        "the file's metadata. Then runs the file with onnxruntime against PyTorch.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron export --out model.onnx   # the default model\n"
        "  grouptron export --checkpoint grouptron-univ-backward --out grouptron.onnx\n"
        "  pip install 'grouptron[export]'   # onnx, onnxscript and onnxruntime",
    )
    export.add_argument(
        "--checkpoint",
        default=DEFAULT_CHECKPOINT,
        help="a .safetensors checkpoint or a shipped name (default: the model predict uses)",
    )
    export.add_argument("--format", choices=EXPORT_FORMATS, default="onnx", help="file format")
    export.add_argument("--out", required=True, help="the file to write (model.onnx)")
    export.add_argument(
        "--no-check", action="store_true", help="skip running the file with onnxruntime"
    )
    add_threads_option(export)
    export.set_defaults(handler=cmd_export)

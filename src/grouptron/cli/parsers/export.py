"""The parser of ``grouptron export`` (its handlers: ``grouptron.cli.export``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import Formatter, add_threads_option, calibration_option
from grouptron.constants import DEFAULT_CHECKPOINT, EXPORT_FORMATS


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
    export.add_argument(
        "--calibration",
        type=calibration_option,
        help="a grouptron calibrate file of this checkpoint, stored in the file's metadata "
        "(grouptron.region_calibration) for the caller's regions (docs/regions.md); default: "
        "the calibration the checkpoint ships with, where it has one; 'none' for none",
    )
    add_threads_option(export)
    export.set_defaults(handler="grouptron.cli.export:cmd_export")

"""Accuracy of a joint trajectory against a reference: ``ipf-jax eval`` (see docs/evaluation.md).

``metrics`` (joint choice, MPJPE, per joint/axis), ``align`` (time interpolation, rigid fit),
``report`` (eval.json, per_frame.csv), ``plots`` (paper figure 7); the command is :mod:`ipf_jax.cli.evaluate`.
"""
from .metrics import ALIGN_MODES, Evaluation, evaluate, evaluate_files, summary_doc
from .report import write_outputs

__all__ = ["ALIGN_MODES", "Evaluation", "evaluate", "evaluate_files", "summary_doc", "write_outputs"]

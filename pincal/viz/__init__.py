"""Pictures: plots, the meshcat scene, the static page, the HTML report (no argparse here)."""

from __future__ import annotations

from pincal.viz.html_report import ReportContent, render_report, write_report
from pincal.viz.scene import CalibrationView, draw_calibration, open_in_meshcat, static_scene

__all__ = [
    "CalibrationView",
    "ReportContent",
    "draw_calibration",
    "open_in_meshcat",
    "render_report",
    "static_scene",
    "write_report",
]

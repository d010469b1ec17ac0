"""What a calibrated URDF carries of its calibration beyond the geometry: the estimates, their covariance and how the
predicted bound grows, so that ``pincal check`` and ``pincal compensate`` give each posture's predicted 95 % bound from
the URDF alone, as they do from the report JSON.

The element ``<pincal_calibration>`` inside ``<robot>`` holds, as JSON text, the report's fields that the predicted
bound reads (:data:`CARRIED`: the parameters' estimates [m, rad], the covariance of the identified ones, the variance
factor, the measurements and markers it was fitted with and the σ of their rows, the payload, the fitted joint ranges
[rad or m], the growth
of the bound and the nominal robot's own bound [m], the registered setup of "before", and each pixel camera's
intrinsics [px, 1], so that ``check`` predicts pixels from the URDF alone). URDF readers ignore
elements they do not know (Pinocchio and yourdfpy both load the file unchanged). docs/calibrated_urdf.md describes it.
"""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from pincal.calibration.report import CalibrationReport
from pincal.errors import DataError

#: The element of a calibrated URDF that carries its calibration.
ELEMENT = "pincal_calibration"
#: The report's fields the element carries.
CARRIED = ("schema_version", "robot", "units", "measurements", "parameters", "covariance", "sigma2", "markers",
           "declared_markers", "payload", "fitted_range", "error_growth", "before_parameters", "selection", "row_sigma",
           "cameras")


def carried_text(report: CalibrationReport) -> str:
    """The ``<pincal_calibration>`` element of ``report``'s calibrated URDF (its JSON text escaped for XML)."""
    content = report.as_dict(CARRIED)
    shown = json.dumps({key: content[key] for key in CARRIED if key in content}, separators=(",", ":"))
    escaped = shown.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return f"<{ELEMENT}>{escaped}</{ELEMENT}>"


def with_carried(urdf_text: str, report: CalibrationReport) -> str:
    """``urdf_text`` with ``report``'s ``<pincal_calibration>`` element as the last child of ``<robot>`` (one it held
    is replaced).

    Raises:
        DataError: the text has no ``</robot>``.
    """
    text = re.sub(rf"\n?[ \t]*<{ELEMENT}>.*?</{ELEMENT}>", "", urdf_text, flags=re.DOTALL)
    end = text.rfind("</robot>")
    if end < 0:
        raise DataError("the calibrated URDF has no </robot>")
    return f"{text[:end]}  {carried_text(report)}\n{text[end:]}"


def read_carried(path: str | Path) -> CalibrationReport | None:
    """The calibration a URDF at ``path`` carries (a report of :data:`CARRIED`'s fields), or None when it carries none
    (a URDF written before pincal carried it; a file that is no XML, which the URDF's reader names).

    Raises:
        DataError: the element is there but is not a calibration's: not JSON, or a field holding what no calibration
            writes (:meth:`~pincal.calibration.report.CalibrationReport.from_json`), naming the file and the field.
    """
    try:
        element = ET.parse(str(path)).getroot().find(ELEMENT)
    except (OSError, ET.ParseError):
        return None
    if element is None or not element.text:
        return None
    where = f"the <{ELEMENT}> element of '{path}'"
    try:
        content: Any = json.loads(element.text)
    except json.JSONDecodeError as exc:
        raise DataError(f"{where} is not JSON ({exc}): a calibrated URDF carries its calibration there as "
                        "'pincal calibrate --out' wrote it; write the file again, or remove the element") from None
    return CalibrationReport.from_json(content, where)

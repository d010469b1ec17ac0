"""``pincal assemble``: a closed-loop URDF's passive joints re-zeroed so that every loop closes at zero."""

from __future__ import annotations

import argparse
import math
from pathlib import Path


def cmd_assemble(args: argparse.Namespace) -> int:
    """``pincal assemble IN --out OUT``: close the loops, say how far each passive joint's origin moved, write OUT."""
    from pincal.errors import RobotFileError
    from pincal.io.files import check_outputs, write_text
    from pincal.io.mesh_files import plan_meshes
    from pincal.model.assembly import assemble_urdf
    from pincal.model.urdf import check_urdf_size

    source = Path(args.urdf)
    if not source.is_file():
        raise RobotFileError(f"URDF file '{args.urdf}' does not exist" if not source.exists()
                             else f"URDF file '{args.urdf}' is not a regular file")
    check_outputs([("--out", args.out)], [source])
    try:
        check_urdf_size(source.stat().st_size, f"URDF file '{args.urdf}'")  # before it is read
        text = source.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RobotFileError(f"cannot read '{source}': {exc}") from None
    assembly = assemble_urdf(text, str(source))
    print(f"loops closed at the zero configuration: largest residual {assembly.residual_before:.3g} m/rad before, "
          f"{assembly.residual_after:.3g} after ({assembly.steps} Gauss-Newton steps on the passive joints)")
    if not assembly.shifts:
        print("no passive joint moved: the file was assembled already")
    for shift in assembly.shifts:
        unit = "mm" if shift.unit == "m" else "mrad"
        value = ("" if math.isnan(shift.value)
                 else f"closes the loops at {shift.value * 1e3:+.4f} {unit}, its new zero; ")
        print(f"  {shift.joint}: {value}origin moved {shift.translation * 1e3:.4f} mm, turned "
              f"{shift.rotation * 1e3:.4f} mrad")
    write_text(args.out, plan_meshes(text, source.parent, args.out).text(assembly.text))
    print(f"wrote {args.out} (only the moved origins' xyz and rpy differ from {args.urdf}; the passive joints' "
          "limits, if any, are as written)")
    return 0


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``assemble`` to the ``pincal`` subcommands."""
    parser = sub.add_parser(
        "assemble", help="close a closed-loop URDF's loops at the zero configuration (passive joints re-zeroed)",
        description="Turn the passive joints (those no <transmission> names), with the actuated ones at zero, until "
                    "every <loop> closes (least-norm Gauss-Newton steps from zero: the assembly nearest the file's "
                    "drawing), and make those values their zero: each one's <origin> absorbs its rotation (or a "
                    "prismatic joint's translation). Link lengths, loop anchors and the actuated joints are kept; "
                    "only the moved origins' xyz and rpy are rewritten. Refused when no values close a loop "
                    "(lengths that do not fit). README, 'A closed-loop URDF'.",
        epilog="example: pincal assemble four_bar_draft.urdf --out four_bar.urdf")
    parser.add_argument("urdf", help="the URDF to assemble, its passive joints' origins approximate")
    parser.add_argument("--out", required=True, help="the assembled URDF to write (never the input)")
    parser.set_defaults(func=cmd_assemble)

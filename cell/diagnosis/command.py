"""The command-line side of the diagnosis: ``musclecell diagnose`` on one measurement set.

Light at import, and never MuJoCo (the diagnosis side runs without it): the handler imports
the rest. The ``--batch`` of many sets is added on top by the sweeps' package
(:func:`cell.scale.command.add_batch`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from cell.cores import default_workers
from cell.errors import InputError
from cell.options import add_out, add_quiet
from cell.outputs import Output, check_outputs


def add_diagnose(commands: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """The ``diagnose`` subcommand for one set; returns its parser, for the batch's options."""
    diagnosis = commands.add_parser(
        "diagnose", help="diagnose a measurement set: what the simulation gets wrong, the "
        "cause, the extended material and the gain on held-out tests")
    diagnosis.add_argument("set_dir", type=Path, nargs="?", metavar="SET_DIR",
                           help="folder with specimen.toml and tests.csv")
    add_out(diagnosis, "one set: write the diagnosis JSON here; --batch: the results folder "
            "(sets already in it are skipped)", required=True, old=("--json",))
    diagnosis.add_argument("--material", type=Path, metavar="FILE",
                           help="write the extended material TOML here (default: next to the "
                           "JSON of --out, <name>-material.toml)")
    diagnosis.add_argument("--report", type=Path, metavar="DIR",
                           help="write plots and a Markdown report in this folder")
    diagnosis.add_argument("--suggest", action="store_true",
                           help="when other models explain the set about as well, name the "
                           "test to run next: the one whose outcome they predict most apart "
                           "(in the JSON's suggestion)")
    add_quiet(diagnosis)
    diagnosis.set_defaults(handler=diagnose_command, uses_mujoco=False)
    return diagnosis


def diagnose_command(args: argparse.Namespace) -> int:
    """``musclecell diagnose SET_DIR --out FILE``: every output checked, then the set read
    whole, then the diagnosis, then the files."""
    if args.set_dir is None:
        raise InputError(None, "SET_DIR",
                         "missing: diagnose SET_DIR --out FILE, or --batch DIR --out DIR")
    if getattr(args, "address", None) is not None:
        raise InputError(None, "--address", "only --batch runs on Ray")
    workers = default_workers() if args.workers is None else args.workers
    if workers < 1:
        raise InputError(None, "--workers", f"must be >= 1, got {workers}")
    material_path = args.material or args.out.with_name(f"{args.out.stem}-material.toml")
    from cell.measure.specimens import SPECIMEN_FILE, TESTS_FILE

    check_outputs([Output(args.out, "--out"),
                   Output(material_path, "--material" if args.material else "--out"),
                   args.report and Output(args.report, "--report", folder=True, whole=True,
                                          marks=("report.md", "cut-report.md"))],
                  [args.set_dir, args.set_dir / SPECIMEN_FILE, args.set_dir / TESTS_FILE])
    if args.report is not None:
        from cell.extras import require

        require("matplotlib", "report", "the diagnosis report")
    from cell.diagnosis.engine.settings import DiagnosisParams
    from cell.diagnosis.sets import diagnose_set
    from cell.measure.specimens import load_measurement_set
    from cell.outputs import json_text
    from cell.tissue.materialfile import material_to_toml

    measurements = load_measurement_set(args.set_dir)  # reads everything before any write
    if args.suggest and not measurements.tests:
        raise InputError(args.set_dir / TESTS_FILE, "mode", "--suggest proposes uniaxial "
                         "tests, and the set holds none (cut tests alone)")
    from cell.progress import progress_bar

    with progress_bar("fit", quiet=args.quiet, desc=args.set_dir.name) as bar:
        result = diagnose_set(measurements, DiagnosisParams(workers=workers), bar.update)
    suggestion = None
    if args.suggest:
        from cell.diagnosis.specimen.suggest import suggest

        suggestion = suggest(result.uniaxial)
    # Both checked before anything is written: a diverged fit (exit 3), a material of no
    # plausible stiffness (exit 2).
    diagnosis = json_text({**result.to_json(), **({} if suggestion is None else
                                                  {"suggestion": suggestion.to_json()})},
                          args.out)
    material = material_to_toml(result.material(), result.material_comment())
    from cell.folders import write_files_and_folders

    report = {}
    if args.report is not None:
        from cell.diagnosis.cut.report import write_set_report

        report[args.report] = lambda folder: write_set_report(result, folder, material_path)
    # The report, the material and the JSON appear together or not at all.
    write_files_and_folders({material_path: material, args.out: diagnosis}, report)
    print(f"causes: {', '.join(result.causes) or 'none (the baseline explains the data)'}\n"
          f"{result.summary()}\n"
          + ("" if suggestion is None else suggestion.summary() + "\n")
          + f"wrote {args.out}, {material_path}"
          + (f", {args.report}" if args.report is not None else ""))
    return 0

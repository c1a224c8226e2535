"""The Living Matter Lab's mean curves of artificial and real meat (``ArtMeat.xlsx`` of
LivingMatterLab/CANN, ``ARTMEAT/DiscoveringMechanics/input``) as measurement sets: per product,
one tension, one compression and one simple shear test in the project's format
(docs/measured-data.md). The file has no licence: fetch it yourself, never commit it or the
sets written from it (docs/benchmarks.md gives the commands).

The sheet holds, per product (column suffix ``ac``, ``tf``, ``rc``), the stretch with the
mean nominal stress (kPa) and the amount of shear with the mean shear stress (kPa), each from
0.9 to 1.1 (-0.1 to 0.1), rising. The sets assume what the sheet does not say: a 10 mm cube
(``--edge-m``), the stresses nominal (force = stress x the initial face area), one sample a
second (the curves are quasi-static means: no rate in them), the shear plane ``fs``.
"""

import argparse
from pathlib import Path

PRODUCTS = {"ac": "artificial chicken (plant-based)", "tf": "tofurky (plant-based deli)",
            "rc": "real chicken (animal deli)"}
HEADER = "test_id,mode,angle_deg,time_s,displacement_m,force_N,shear_plane"


def read_sheet(path: Path) -> dict[str, list[float]]:
    """The first sheet's columns by header (the two ``sem`` columns of a product keep their
    order under one header: only the means are read)."""
    import openpyxl  # the xlsx extra: only this script reads Excel files

    rows = list(openpyxl.load_workbook(path, read_only=True, data_only=True).worksheets[0]
                .iter_rows(values_only=True))
    columns: dict[str, list[float]] = {}
    for k, name in enumerate(rows[0]):
        columns.setdefault(str(name), [float(row[k]) for row in rows[1:] if row[k] is not None])
    return columns


def tests_rows(columns: dict[str, list[float]], product: str, edge_m: float) -> list[str]:
    """The product's tension, compression and shear tests as rows of ``tests.csv``, each from
    the unloaded state outwards."""
    area_m2 = edge_m * edge_m
    stretch, stress = columns[f"stretch_{product}"], columns[f"stress_{product}[kPa]"]
    gamma, shear = columns[f"gamma_{product}"], columns[f"shear_{product}[kPa]"]
    tension = [(s - 1.0, p) for s, p in zip(stretch, stress, strict=True) if s >= 1.0 - 1e-9]
    compression = [(s - 1.0, p) for s, p in zip(stretch, stress, strict=True)
                   if s <= 1.0 + 1e-9][::-1]
    shearing = [(g, t) for g, t in zip(gamma, shear, strict=True) if g >= -1e-9]
    rows = []
    for test_id, mode, plane, curve in (("t", "tension", "", tension),
                                        ("c", "compression", "", compression),
                                        ("s", "shear", "fs", shearing)):
        angle = "" if mode == "shear" else "0"
        rows += [f"{test_id},{mode},{angle},{k},{strain * edge_m:.9g},"
                 f"{stress_kpa * 1e3 * area_m2:.9g},{plane}"
                 for k, (strain, stress_kpa) in enumerate(curve)]
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("xlsx", type=Path, help="ArtMeat.xlsx")
    parser.add_argument("out", type=Path, help="folder to write one set per product into")
    parser.add_argument("--products", nargs="+", default=list(PRODUCTS), choices=PRODUCTS)
    parser.add_argument("--edge-m", type=float, default=0.010,
                        help="the assumed cube's edge, m (default 0.010)")
    args = parser.parse_args()
    columns = read_sheet(args.xlsx)
    for product in args.products:
        folder = args.out / f"artmeat-{product}"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "specimen.toml").write_text(
            f'[specimen]\nname = "{PRODUCTS[product]}"\n'
            f"size_m = [{args.edge_m}, {args.edge_m}, {args.edge_m}]\n\n"
            f'[rig]\nsource = "LivingMatterLab/CANN ArtMeat.xlsx, mean curves ({product})"\n')
        (folder / "tests.csv").write_text(
            "\n".join([HEADER, *tests_rows(columns, product, args.edge_m)]) + "\n")
        print(f"wrote {folder}")


if __name__ == "__main__":
    main()

"""Read one C3D file with ezc3d, in a process of its own (see `c3d._read_in_child`).

    python -m hotu_drake.motion.c3d_child FILE.c3d OUT.npz MEMORY_BYTES

ezc3d is C++: a hostile file can crash it, make it hang or make it allocate
without bound. The parent gives this process a time limit; the memory
limit is set here. Writes the points, residuals, labels and the POINT
parameters the reader needs to OUT.npz, or prints one line on failure and
exits with 1. It imports numpy and ezc3d only (and the small `motion` package), so it starts fast.
"""

import json
import resource
import sys

import numpy as np


def _labels(point) -> list[str]:
    """POINT:LABELS, continued in LABELS2, LABELS3, ... for large marker sets."""
    labels = list(point["LABELS"]["value"]) if "LABELS" in point else []
    k = 2
    while f"LABELS{k}" in point:
        labels += list(point[f"LABELS{k}"]["value"])
        k += 1
    return [str(label).strip() for label in labels]


def main(path: str, out: str, memory: int) -> int:
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    try:
        import ezc3d

        c3d = ezc3d.c3d(path)
        point = c3d["parameters"]["POINT"]
        units = point.get("UNITS", {}).get("value", [])
        screen = point.get("Y_SCREEN", {}).get("value", [])
        np.savez(
            out,
            points=np.asarray(c3d["data"]["points"], dtype=float)[:3].transpose(1, 2, 0),  # (n, T, 3)
            residuals=np.asarray(c3d["data"]["meta_points"]["residuals"], dtype=float)[0],
            labels=np.array(json.dumps(_labels(point))),
            rate=np.array(float(np.ravel(point["RATE"]["value"])[0])),
            declared=np.array(int(np.ravel(point["FRAMES"]["value"])[0]) if "FRAMES" in point else 0),
            units=np.array(str(units[0]).strip().lower() if len(units) else ""),
            y_screen=np.array(str(screen[0]) if len(screen) else ""),
        )
    except (MemoryError, Exception) as error:  # noqa: BLE001  (any failure is the file's: one line to the parent)
        lines = str(error).strip().splitlines()
        print(lines[0][:100] if lines else type(error).__name__, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2], int(sys.argv[3])))

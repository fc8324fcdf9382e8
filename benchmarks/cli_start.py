"""How fast the command line starts (issue 25): CPU and wall seconds of `femu --help` and of
`femu COMMAND --help` in a fresh interpreter, best of 3, for each source tree given (default:
this one), e.g. to compare with another checkout:

    python benchmarks/cli_start.py . /path/to/other/checkout

On a shared machine the wall time follows the load; the CPU time is the figure to compare.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time

COMMANDS = (["--help"], ["model", "--help"], ["study", "--help"], ["diagnose", "--help"], ["reproduce", "--help"])


def timed(tree: str, args: list[str], repeats: int = 3) -> tuple[float, float]:
    """(best CPU s, best wall s) of `femu ARGS` run from the source tree `tree`."""
    env = dict(os.environ, PYTHONPATH=os.path.abspath(tree))
    best_cpu = best_wall = float("inf")
    for _ in range(repeats):
        r0, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
        subprocess.run([sys.executable, "-c", "import sys; from femu.cli import main; sys.exit(main())", *args],
                       env=env, stdout=subprocess.DEVNULL, check=True)
        wall, r1 = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN)
        best_cpu = min(best_cpu, r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
        best_wall = min(best_wall, wall)
    return best_cpu, best_wall


def main(trees: list[str]) -> None:
    print(f"load average {os.getloadavg()[0]:.1f}")
    for tree in trees:
        for args in COMMANDS:
            cpu, wall = timed(tree, args)
            print(f"{tree:30} femu {' '.join(args):20} CPU {cpu:.3f} s  wall {wall:.3f} s", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or ["."])

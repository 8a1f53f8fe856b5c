"""What `python engine.py --smoke` says under each address-space limit (`ulimit -v`): exit code and stderr.

    python tools/memory_limits.py                 # --no-rerun, 40 MB to 200 MB
    python tools/memory_limits.py --rerun         # with its recording, 300 MB to 2 GB

Each limit is one fresh process, limited before it starts (as `ulimit -v` in a shell). Which library fails
first, and how, moves with the limit: docs/DEVELOPING.md ("Signals, memory limits, closed streams") pastes
this output. Not a test (pytest does not collect it): the lines below our own are other libraries' words.
"""

import argparse
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIMITS_MB = {False: [40, 60, 80, 100, 120, 130, 140, 150, 200], True: [300, 500, 600, 700, 800, 1000, 1500, 2000]}


def run_under(limit_mb: int, rerun: bool) -> tuple[int, list]:
    def limited():
        resource.setrlimit(resource.RLIMIT_AS, (limit_mb * 2**20, limit_mb * 2**20))

    with tempfile.TemporaryDirectory() as out:
        command = [sys.executable, str(ROOT / "engine.py"), "--smoke", "--out", out, *([] if rerun else ["--no-rerun"])]
        done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, preexec_fn=limited, timeout=300)
    return done.returncode, done.stderr.splitlines()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rerun", action="store_true", help="write the recording too (Rerun loads)")
    args = parser.parse_args()
    print(f"python engine.py --smoke{'' if args.rerun else ' --no-rerun'} under ulimit -v:")
    for limit in LIMITS_MB[args.rerun]:
        code, lines = run_under(limit, args.rerun)
        said = f"{lines[0][:72].rstrip()}" + (f" (+{len(lines) - 1} lines)" if len(lines) > 1 else "") if lines else "-"
        print(f"{limit:>6} MB  exit {code:<4} {said}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

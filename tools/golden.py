"""Write tests/golden/smoke_NAME.json for every declared system: what `python engine.py --smoke --no-rerun
--system NAME` writes today. After a deliberate change to a system or an integrator (a new one, too):

    python tools/golden.py          # then read `git diff tests/golden` line by line before committing

The golden files are the course CI's byte-for-byte reference: a change there is a change every student sees.
"""

import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
import engine  # noqa: E402


def main() -> int:
    golden = REPO / "tests" / "golden"
    with tempfile.TemporaryDirectory() as scratch:
        for name in engine.SYSTEMS:
            out = Path(scratch) / name
            subprocess.run([sys.executable, str(REPO / "engine.py"), "--smoke", "--no-rerun", "--system", name,
                            "--out", str(out)], check=True, stdout=subprocess.DEVNULL)
            target = golden / f"smoke_{name}.json"
            before = target.read_bytes() if target.exists() else None
            target.write_bytes((out / "metrics.json").read_bytes())
            print(f"{target.relative_to(REPO)}: {'unchanged' if before == target.read_bytes() else 'WRITTEN'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Print one SHA-256 over every position and energy of the 9 chapter runs (3 systems x 3 integrators).

    OPENBLAS_CORETYPE=Haswell python tools/fingerprint.py
    OPENBLAS_CORETYPE=SkylakeX python tools/fingerprint.py        # only on a CPU with AVX-512
    NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL" python tools/fingerprint.py

Same hash under every setting: the physics does not depend on the BLAS kernel or SIMD level.
"""

import hashlib
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import engine  # noqa: E402


def fingerprint() -> str:
    digest = hashlib.sha256()
    for system_name in ("orbit", "spring", "freefall"):
        for integrator in engine.CHAPTER_INTEGRATORS:
            system = engine.build_system(system_name, np.random.default_rng(0))
            positions, velocities, energies = engine.simulate(engine.INTEGRATORS[integrator], system, 0.01, 2000)
            digest.update(positions.tobytes())
            digest.update(velocities.tobytes())
            digest.update(energies.tobytes())
    return digest.hexdigest()


if __name__ == "__main__":
    print(fingerprint())

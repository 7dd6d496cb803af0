"""granular_chain: discrete-element dynamics of one-dimensional chains of granules.

Data flows one way: scene file -> :class:`Scene` -> packed :class:`Model` ->
compiled kernel -> :class:`Result` -> writers. See README.md.
"""

import hashlib as _hashlib
from pathlib import Path as _Path


#: Sub-packages without numba kernels that no kernel's module imports (checked by
#: tests/test_import_graph.py): their sources do not enter the kernels' digest.
KERNEL_FREE = ("cli", "classics", "__main__.py")


def _drop_stale_kernels() -> None:
    """Delete the package's cached numba kernels when any of its sources changed.

    numba keys each cached kernel on its own file only; our kernels inline the
    laws of other modules, so after an edit or upgrade of, say, laws/friction.py
    a cached kernel would keep the old machine code. A digest of the sources is
    kept beside the cache; when it differs the package's .nbi/.nbc files go.
    The command line and the classic experiments (``KERNEL_FREE``) are left out of
    the digest: they hold no kernel and no kernel's module imports them
    (tests/test_import_graph.py), so editing them keeps the compiled kernels.
    (A cache moved elsewhere with NUMBA_CACHE_DIR is not touched.)
    """
    root = _Path(__file__).resolve().parent
    sources = [f for f in sorted(root.rglob("*.py"))
               if f.relative_to(root).parts[0] not in KERNEL_FREE]
    try:
        digest = _hashlib.sha1(b"".join(f.read_bytes() for f in sources))
        stamp = root / "__pycache__" / "numba_sources.sha1"
        if stamp.exists() and stamp.read_text() == digest.hexdigest():
            return
        for cache in root.rglob("__pycache__"):
            for f in [*cache.glob("*.nbi"), *cache.glob("*.nbc")]:
                f.unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:  # a read-only installation: nothing to clean, nothing to stamp
        pass


_drop_stale_kernels()

from .errors import SimulationError  # noqa: E402
from .extras import MissingExtraError  # noqa: E402
from .laws.contact import register_contact_law  # noqa: E402
from .notices import (  # noqa: E402
    CompileNotice,
    GranularChainWarning,
    OverlapWarning,
    PlotSkippedWarning,
    TimeStepWarning,
)
from .readback import read_run  # noqa: E402
from .result import Event, Result, Status  # noqa: E402
from .scene import Scene, SceneError, load_scene, scene_from_dict  # noqa: E402
from .simulate import simulate  # noqa: E402
from .version import __version__  # noqa: E402

__all__ = ["Scene", "SceneError", "load_scene", "scene_from_dict", "simulate", "Result",
           "Status", "Event", "SimulationError", "read_run", "MissingExtraError",
           "GranularChainWarning", "OverlapWarning", "TimeStepWarning", "PlotSkippedWarning",
           "CompileNotice", "register_contact_law"]

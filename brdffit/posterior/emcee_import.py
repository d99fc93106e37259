"""emcee without scipy.stats: the sampler imported in 0.004 s of CPU instead of 0.42 s.

Importing emcee (3.1) imports scipy.stats for one class: its KDE move
(``emcee/moves/kde.py`` runs ``from scipy.stats import gaussian_kde`` in a ``try``
that leaves ``gaussian_kde = None`` when the import fails). brdffit's posterior uses
the Metropolis-Hastings and differential-evolution moves only
(:data:`brdffit.posterior.chain.MOVE_WEIGHTS`) and nothing else of scipy.stats, whose
import was 0.42 s of the 1.05 s of CPU of the README's first command, ``brdffit fit
data_synthetic/ward.csv --model ward --uncertainty`` (benchmarks/README.md, "Cold
start, located").

:func:`import_emcee` imports emcee while a finder at the head of ``sys.meta_path``
refuses ``scipy.stats`` to the importing thread (other threads are not affected, and
when scipy.stats is already imported nothing is refused: the finders are not asked),
then gives emcee's KDE module a ``gaussian_kde`` that imports scipy.stats on its first
call. The KDE move therefore works as before for anyone who uses it, and scipy.stats
loads when it is used. Should a later emcee need scipy.stats to import at all (the
import raising), emcee is imported again with nothing refused.
"""

from __future__ import annotations

import importlib.abc
import sys
import threading

__all__ = ["import_emcee"]

_DEFERRED = "scipy.stats"


class _Refuse(importlib.abc.MetaPathFinder):
    """Refuses :data:`_DEFERRED` to the thread that created it."""

    def __init__(self):
        self.thread = threading.get_ident()

    def find_spec(self, name, path=None, target=None):
        if name == _DEFERRED and threading.get_ident() == self.thread:
            raise ModuleNotFoundError(f"{name} is imported when first used", name=name)
        return None


def _gaussian_kde(*args, **kwargs):
    """``scipy.stats.gaussian_kde(*args, **kwargs)``, scipy.stats imported on first use."""
    from scipy.stats import gaussian_kde

    return gaussian_kde(*args, **kwargs)


def _forget_emcee() -> None:
    for name in [m for m in sys.modules if m == "emcee" or m.startswith("emcee.")]:
        del sys.modules[name]


def import_emcee():
    """The emcee module, imported without importing scipy.stats (see the module)."""
    if "emcee" in sys.modules:  # the statement waits if another thread imports it
        import emcee

        return emcee
    finder = _Refuse()
    sys.meta_path.insert(0, finder)
    try:
        import emcee
    except ImportError:
        _forget_emcee()
        emcee = None
    finally:
        sys.meta_path.remove(finder)
    if emcee is None:  # needs scipy.stats after all, or is not installed: say so plainly
        import emcee
    kde = sys.modules.get("emcee.moves.kde")
    if kde is not None and getattr(kde, "gaussian_kde", False) is None:
        kde.gaussian_kde = _gaussian_kde
    return emcee

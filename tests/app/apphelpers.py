"""Helpers for the page tests (imported as ``apphelpers``)."""

from __future__ import annotations

from streamlit.testing.v1 import AppTest


def no_exception(at: AppTest) -> None:
    assert not at.exception, [e.value for e in at.exception]


def texts(at: AppTest) -> str:
    """All the markdown, captions, titles and messages of the page as one text."""
    parts = []
    for kind in ("title", "header", "subheader", "markdown", "caption", "info", "warning", "error",
                 "success", "toast"):
        try:
            parts += [str(e.value) for e in getattr(at, kind)]
        except (AttributeError, KeyError):
            pass
    return "\n".join(parts)


def save_runs(db, days: dict[str, int]) -> None:
    """Saved Simulation lab runs beside the database ``db``: run name -> days, one participant (P01),
    CACAS, and a by-preference table (the heatmap's)."""
    import pandas as pd

    from cacas import saved_runs

    for name, n in days.items():
        daily = pd.DataFrame({"participant": ["P01"] * n, "method": ["cacas"] * n, "day": range(1, n + 1),
                              "success_rate": [0.5] * n, "preference_accuracy": [0.5] * n,
                              "cumulative_feedback": range(5, 5 * n + 1, 5), "interactions": [15] * n})
        by_pref = daily[["participant", "method", "day"]].assign(
            preference=1, label="Cough: pain check", activity="cough", action="pain check", states=40, correct=20,
            accuracy=0.5)
        saved_runs.save_run(saved_runs.runs_dir(db), name, daily, pd.DataFrame({"participant": ["P01"]}), {},
                             by_pref)


def open_tab(at: AppTest, key: str, label: str) -> AppTest:
    """Open the tab ``label`` of the ``st.tabs`` with key ``key`` (tabs that run only when open) and
    rerun the page, as a click on the tab does."""
    at.session_state[key] = label
    return at.run()


def open_expander(at: AppTest, key: str, opened: bool = True) -> AppTest:
    """Open (or close) the expander with key ``key`` (one drawn only while open: ``on_change="rerun"``)
    and rerun the page, as a click on its label does."""
    at.session_state[key] = opened
    return at.run()


def cache_of(name: str):
    """The ``st.cache_resource`` or ``st.cache_data`` cache of the function ``name`` (as Streamlit names it:
    ``__main__._library_files`` for a page's ``_library_files``, ``pages.ui.recognizer``...), once it has been called; None
    before. Streamlit keeps a cache per function, process-wide, as a server does for its sessions."""
    from streamlit.runtime.caching import cache_data_api, cache_resource_api

    for caches in (cache_resource_api._resource_caches, cache_data_api._data_caches):
        for by_key in list(caches._function_caches.values()):
            for cache in list(by_key.values()):
                if cache.display_name == name:
                    return cache
    return None

"""Long work runs in the background: the page shows progress, other pages (another browser tab)
keep answering, and a second click does not start the work twice."""

import threading

from apphelpers import no_exception, texts

from cacas.jobs import RUNNER


def test_adaptation_in_the_background(app, store, monkeypatch, quick_policy):
    import cacas.study_day

    store.add_participant("P01")
    day = store.open_day("P01")
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
    gate, calls = threading.Event(), []

    def slow_adapt(db_path, participant, day, method="cacas", seed=0, progress=None):
        calls.append(participant)
        progress(0.3, "training SAC against the decision model")
        assert gate.wait(60)
        raise ValueError("stopped by the test")

    monkeypatch.setattr(cacas.study_day, "adapt_day", slow_adapt)
    tab1 = app("pages/adaptation.py", participant="P01")
    tab1.checkbox(key=f"close-short-P01-{day}").check().run()  # 1 of about 15: the researcher says so
    next(b for b in tab1.button if b.label == f"Close day {day} and adapt").click().run()
    no_exception(tab1)
    job = RUNNER.get(f"adapt:{store.path}:P01:{day}")
    assert job is not None and job.running
    assert not any(b.label.startswith("Close day") for b in tab1.button)  # no second start button

    # another tab: the overview and the tablet answer while the adaptation runs
    tab2 = app(participant="P01")
    no_exception(tab2)
    assert "Next for P01" in texts(tab2)
    tab3 = app("pages/adaptation.py", participant="P01")  # the adaptation page in a third tab
    no_exception(tab3)
    assert not any(b.label.startswith("Close day") for b in tab3.button)
    assert job.running and calls == ["P01"]  # started once

    gate.set()
    assert job.wait(30)
    tab1.run()
    no_exception(tab1)
    assert "The adaptation failed: stopped by the test" in texts(tab1)
    assert calls == ["P01"]

"""Sounds and scenes: the sound library (33 activities, playable), new clips by upload or recording,
training and evaluating the sound CNN and the scene ResNet-18, and trying a clip or a photo
(Sections IV-A and V-A)."""

from __future__ import annotations

import pandas as pd
import streamlit as st

from cacas import app_support, lab, spaces
from cacas.audio.library import clip_paths
from cacas.errors import CacasError
from cacas.jobs import DONE, FAILED, RUNNER
from cacas.plots_recognition import confusion_figure
from pages import ui

ui.require_app()

st.title("Sounds and scenes")
st.caption("The robot knows the context from what it hears (33 sound activities; MFCC 64 x 32 and a 3-layer CNN) "
           "and what it sees (6 home scenes; ResNet-18). The shipped library is synthetic (generated "
           "procedurally; no real household recordings can be downloaded here): add your own recordings for a "
           "real study. The paper's 94.7% sound accuracy is on real recordings.")


def _recognise(kind: str, name: str, data: bytes) -> None:
    """Recognise an uploaded or recorded sound clip, or a photo, with the current model; show
    the label and the top 3 (one message if there is no model or the file is bad)."""
    model = ui.recognizer(kind)
    if model is None:
        st.warning(f"No {kind} model yet: train one first.")
        return
    recognise = lab.recognize_sound_bytes if kind == "sound" else lab.recognize_scene_bytes
    try:
        r = recognise(model, name, data)
    except CacasError as exc:
        st.error(str(exc), icon=":material/error:")
        return
    if kind == "scene":
        st.image(data, width=280)
    else:  # hear what the model heard
        st.audio(data, format=lab.audio_mime(name))
    st.markdown(f"### {r.label}")
    if r.short:
        st.warning(f"The clip is {r.seconds:.2f} s long: the model hears 1-s windows, so it heard mostly the "
                   "silence that pads it, and the result says little. Record at least a second.",
                   icon=":material/timer:")
    if r.unsure:
        what = "sound activities" if kind == "sound" else "home scenes"
        st.warning(f"Unsure: {100 * r.confidence:.0f}% for {r.label}. It may be none of the "
                   f"{len(r.probabilities)} {what} the model knows.", icon=":material/help:")
    st.dataframe(pd.DataFrame(r.top3, columns=["activity" if kind == "sound" else "scene", "probability"]),
                 hide_index=True, column_config={"probability": st.column_config.ProgressColumn(
                     min_value=0.0, max_value=1.0, format="percent")})


def _clip_keys() -> tuple[str, str]:
    """The upload and recording widgets' keys: new ones after clips are added, which empties them
    (a file left in the uploader invited adding it twice)."""
    n = st.session_state.get("clip-round", 0)
    return f"clip-upload-{n}", f"clip-record-{n}"


def _add_clips() -> None:
    s = st.session_state
    upload_key, record_key = _clip_keys()
    files = [(f.name, f.getvalue()) for f in (s.get(upload_key) or [])]
    rec = s.get(record_key)
    if rec is not None:
        files.append(("recording.wav", rec.getvalue()))
    try:
        added = lab.add_clips(s["clip-activity"], files)
    except CacasError as exc:
        s["clip-error"], s["clip-added"] = str(exc), None
        return
    s["clip-error"], s["clip-added"] = None, f"Added {len(added)} clip(s) to '{s['clip-activity']}'."
    s["clip-round"] = s.get("clip-round", 0) + 1
    st.cache_data.clear()


@st.cache_data(show_spinner=False)
def _library_counts() -> pd.DataFrame:
    rows = []
    for a in spaces.ACTIVITIES:
        try:
            n = len(clip_paths(a))
        except CacasError:
            n = 0
        rows.append({"activity": a, "clips": n})
    return pd.DataFrame(rows)


library, add, train, tryit = st.tabs(["Sound library", "Add clips", "Train and evaluate", "Try a clip or a photo"])

with library:
    counts = _library_counts()
    st.markdown(f"**{int(counts['clips'].sum())} clips** for **{int((counts['clips'] > 0).sum())} of 33** activities.")
    cols = st.columns(3)
    for i, row in counts.iterrows():
        with cols[i % 3].container(border=True):
            st.markdown(f"**{i + 1}. {row['activity']}** · {row['clips']} clip(s)")
            paths = clip_paths(row["activity"]) if row["clips"] else []
            if paths:
                st.audio(str(paths[0]), format=lab.audio_mime(paths[0]))
            else:
                st.caption("No clip yet.")
    with st.expander("Every clip of one activity"):
        act = st.selectbox("Activity", spaces.ACTIVITIES, key="lib-activity")
        for p in clip_paths(act)[:40]:
            st.caption(p.name)
            st.audio(str(p), format=lab.audio_mime(p))

with add:
    st.markdown("Add recordings of one activity: WAV, FLAC or OGG, any sample rate (resampled to 32 kHz, mixed "
                "to mono). Every file is checked before anything is added.")
    st.selectbox("Activity", spaces.ACTIVITIES, key="clip-activity")
    upload_key, record_key = _clip_keys()
    st.file_uploader("Upload clips", type=["wav", "flac", "ogg"], accept_multiple_files=True, key=upload_key)
    st.audio_input("Or record one", key=record_key, sample_rate=32000)
    st.button("Add to the library", type="primary", on_click=_add_clips, icon=":material/library_add:")
    if st.session_state.get("clip-error"):
        st.error(st.session_state["clip-error"], icon=":material/error:")
    if st.session_state.get("clip-added"):
        st.success(st.session_state["clip-added"], icon=":material/check_circle:")


def _metrics_view(metrics, kind: str) -> None:
    st.metric(f"{kind} test accuracy", f"{100 * metrics.accuracy:.1f}%", help=f"on {metrics.n} held-out items")
    st.plotly_chart(confusion_figure(metrics), width="content", key=f"cm-{kind}")
    per = metrics.per_class.rename(columns={"label": "class"})
    st.dataframe(per, hide_index=True, width="stretch",
                 column_config={"accuracy": st.column_config.NumberColumn(format="percent")})


with train:
    for kind, trainer, evaluator in (("Sound", lab.train_sound, lab.evaluate_sound),
                                     ("Scene", lab.train_scene, lab.evaluate_scene)):
        st.subheader(f"{kind} model")
        model = ui.recognizer(kind.lower())
        if model is None:
            st.caption("No trained model saved yet.")
        else:
            meta = model.metadata
            data = meta.get("training_data", {})
            st.caption(f"Trained {app_support.short_time(meta.get('trained', '?'))} · test accuracy "
                       f"{100 * float(meta.get('accuracy', float('nan'))):.1f}% · "
                       f"{data.get('recordings', data.get('images', '?'))} items"
                       f"{' (synthetic)' if data.get('synthetic') else ''} · "
                       f"{meta.get('training_seconds', '?')} s")
            now = int(_library_counts()["clips"].sum()) if kind == "Sound" else None
            if now is not None and data.get("recordings") not in (None, now):
                st.caption(f":material/update: The sound library holds {now} clips now ({data['recordings']} when "
                           "this model was trained): train it again to use them.")
        key_train, key_eval = f"train-{kind.lower()}", f"eval-{kind.lower()}"
        busy = any(RUNNER.get(k) is not None and RUNNER.get(k).running for k in (key_train, key_eval))
        c1, c2 = st.columns(2)
        took = (model.metadata.get("training_seconds") if model is not None else None)
        if c1.button(f"Train the {kind.lower()} model", disabled=busy, key=f"btn-{key_train}",
                     icon=":material/model_training:",
                     help=("Runs in the background; " + (f"the saved model took {float(took) / 60:.0f} min to train."
                                                         if took else "several minutes on 2 CPU cores."))):
            RUNNER.start(key_train, trainer, label=f"Training the {kind.lower()} model")
            st.rerun()
        if c2.button(f"Evaluate the saved {kind.lower()} model", disabled=busy or model is None,
                     key=f"btn-{key_eval}", icon=":material/fact_check:"):
            RUNNER.start(key_eval, evaluator, label=f"Evaluating the {kind.lower()} model")
            st.rerun()
        jobs = [j for j in (ui.job_progress(k, stoppable=True) for k in (key_train, key_eval)) if j is not None]
        ended = [j for j in jobs if not j.running]
        last = max(ended, key=lambda j: j.finished or 0) if ended and not busy else None
        if last is not None and last.status == FAILED:  # the latest result only, never under running work
            st.error(f"{last.label} failed: {last.error}", icon=":material/error:")
        elif last is not None and last.status == DONE:
            st.caption(f"{last.label}: finished {app_support.short_time(last.finished)}.")
            _metrics_view(getattr(last.result, "metrics", last.result), kind)


with tryit:
    st.caption("Each model always answers with one of the classes it knows (33 activities, 6 scenes): a sound or "
               "a photo of none of them can still get a high probability, so a sure answer is not proof.")
    c1, c2 = st.columns(2)
    with c1:
        st.markdown("**A sound**")
        up = st.file_uploader("Clip", type=["wav", "flac", "ogg"], key="try-clip")
        rec = st.audio_input("Or record", key="try-record", sample_rate=32000)
        clip = up or rec
        if clip is not None:
            _recognise("sound", getattr(clip, "name", "recording.wav"), clip.getvalue())
    with c2:
        st.markdown("**A photo**")
        photo = st.file_uploader("Photo", type=["png", "jpg", "jpeg"], key="try-photo")
        if photo is not None:
            _recognise("scene", photo.name, photo.getvalue())

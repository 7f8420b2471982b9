"""Sounds and scenes: the sound library (33 activities, playable) and the scene library (6 rooms),
new clips by upload or recording and new photos by upload or camera, training and evaluating the
sound CNN and the scene ResNet-18, and trying a clip or a photo (Sections IV-A and V-A)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import streamlit as st

from cacas import app_support, lab, spaces, table_layouts
from cacas.audio.library import clip_paths
from cacas.vision.library import image_paths
from cacas.errors import CacasError
from cacas.jobs import DONE, FAILED, RUNNER
from cacas.plots_recognition import confusion_figure
from cacas.previous_model import model_words
from cacas.recognition import evaluated_on, short_clip_warning, unsure_words
from pages import ui

ui.require_app()

st.title("Sounds and scenes", anchor=False)
st.caption("The robot knows the context from what it hears (33 sound activities; MFCC 64 x 32 and a 3-layer CNN) "
           "and what it sees (6 home scenes; ResNet-18). The shipped library is synthetic (generated "
           "procedurally; no real household recordings can be downloaded here): add your own clips and "
           "photos of the participant's rooms for a real study. The paper's 94.7% sound accuracy is on real "
           "recordings.")


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
        # as the model sees it (a 16-bit PNG could not be drawn); named for a screen reader (it had no alt text)
        st.image(lab.photo_to_show(name, data), width=280, alt=f"The photo {name}, as the model sees it")
    else:  # hear what the model heard
        st.audio(data, format=lab.audio_mime(name))
    st.markdown(f"### {r.label}", anchors=False)  # no anchor-link icon beside it, as on the tablet's headings
    if r.short:
        st.warning(f"The clip {short_clip_warning(r.seconds)}.", icon=":material/timer:")
    if r.unsure:
        st.warning(f"Unsure: {unsure_words(r, kind)}.",
                   icon=":material/help:")
    # whole percents, as the warning above says its share ("percent" gave "49.96%" beside "Unsure: 49%"), and "<1%"
    # for a share that rounds to 0 (a progress column's number format said "0%"); the bar beside it, unlabelled
    top3 = pd.DataFrame(r.top3_words, columns=["activity" if kind == "sound" else "scene", "probability"])
    top3["bar"] = [100 * p for _, p in r.top3]
    st.dataframe(top3, hide_index=True, column_config={"bar": st.column_config.ProgressColumn(
        " ", min_value=0, max_value=100, format=" ", width="small")})


#: What each library's pages say and use: the Table I names, the page's words, the file types.
_KINDS = {
    "sound": dict(names=spaces.ACTIVITIES, label="activity", item="clip", items="clips",
                  add=lab.add_clips, paths=clip_paths, types=["wav", "flac", "ogg"]),
    "scene": dict(names=spaces.SCENES, label="room", item="photo", items="photos",
                  add=lab.add_photos, paths=image_paths, types=["jpg", "jpeg", "png", "bmp", "webp"]),
}


def _upload_keys(kind: str) -> tuple[str, str]:
    """The upload and recording (or camera) widgets' keys: new ones after files are added, which
    empties them (a file left in the uploader invited adding it twice)."""
    n = st.session_state.get(f"{kind}-round", 0)
    return f"{kind}-upload-{n}", f"{kind}-capture-{n}"


def _chosen(kind: str) -> tuple[str | None, list, object]:
    """The activity or room chosen, the uploaded files and the recording (or photo), as the
    widgets hold them now."""
    s = st.session_state
    upload_key, capture_key = _upload_keys(kind)
    return s.get(f"{kind}-add-name"), list(s.get(upload_key) or []), s.get(capture_key)


def _choice(kind: str) -> tuple:
    """What an Add is given: the name and each file's upload id. A refusal is shown while the
    researcher's choice is the one refused, and goes once they change the files or the name."""
    name, uploads, captured = _chosen(kind)
    return name, tuple(f.file_id for f in uploads), None if captured is None else captured.file_id


def _refuse(kind: str, message: str) -> None:
    s = st.session_state
    s[f"{kind}-error"], s[f"{kind}-added"], s[f"{kind}-notes"] = (message, _choice(kind)), None, []


def _add(kind: str) -> None:
    """Add the uploaded (and recorded or photographed) files to the library, all or nothing."""
    s, k = st.session_state, _KINDS[kind]
    name, uploads, captured = _chosen(kind)
    files = [(f.name, f.getvalue()) for f in uploads]
    if captured is not None:
        files.append(("recording.wav" if kind == "sound" else "camera.jpg", captured.getvalue()))
    if name is None:  # nothing preset: a clip added to the first activity in the list would train the model wrong
        _refuse(kind, f"Choose the {k['label']} the {k['items']} are of; nothing was added.")
        return
    try:
        added = k["add"](name, files)
    except CacasError as exc:
        _refuse(kind, str(exc))
        return
    s[f"{kind}-error"], s[f"{kind}-added"] = None, f"Added {app_support.counted(len(added), k['item'], k['items'])} to '{name}'."
    # a clip named as uploaded ("my cough.wav"), and as stored where that differs
    s[f"{kind}-notes"] = lab.long_clip_notes(name, added, given=[f for f, _ in files]) if kind == "sound" else []
    s[f"{kind}-round"] = s.get(f"{kind}-round", 0) + 1
    st.cache_data.clear()


def _library_counts(kind: str) -> pd.DataFrame:
    """Files in the library for each activity ("sound") or room ("scene"), as the folders hold
    them now (a clip added by ``cacas sound import`` while the app runs is counted)."""
    return _counts(kind, lab.library_stamp(kind))


@st.cache_data(show_spinner=False, max_entries=16)
def _library_problem(kind: str, stamp: tuple) -> str | None:
    return lab.library_problem(kind)


@st.cache_data(show_spinner=False, max_entries=16)
def _counts(kind: str, stamp: tuple) -> pd.DataFrame:
    k = _KINDS[kind]
    rows = []
    for name in k["names"]:
        try:
            n = len(k["paths"](name))
        except CacasError:
            n = 0
        rows.append({k["label"]: name, k["items"]: n})
    return pd.DataFrame(rows)


def _add_tab(kind: str, intro: str) -> None:
    """Upload files (or record a clip / take a photo) of one activity or room and add them."""
    k = _KINDS[kind]
    st.markdown(intro)
    st.selectbox(k["label"].capitalize(), k["names"], key=f"{kind}-add-name", index=None,
                 placeholder=f"choose the {k['label']} of the {k['items']}")
    upload_key, capture_key = _upload_keys(kind)
    st.file_uploader(f"Upload {k['items']}", type=k["types"], accept_multiple_files=True, key=upload_key)
    if kind == "sound":
        st.audio_input("Or record one", key=capture_key, sample_rate=32000)
    else:
        with st.expander("Or take one with this device's camera"):
            st.camera_input("Take a photo", key=capture_key)
    ui.button(st, lab.ADD_BUTTON, _add, args=(kind,), type="primary", icon=":material/library_add:",
              key=f"{kind}-add")
    refused = st.session_state.get(f"{kind}-error")
    if refused and refused[1] == _choice(kind):  # once the files or the name are changed, it is of the past
        st.error(refused[0], icon=":material/error:")
    if st.session_state.get(f"{kind}-added"):
        st.success(st.session_state[f"{kind}-added"], icon=":material/check_circle:")
        for note in st.session_state.get(f"{kind}-notes", []):  # a long clip weighs its activity in training
            st.warning(note, icon=":material/timer:")


def _photo_alt(path) -> str:
    """A library photo's text for a screen reader: its room (its folder, "dining_room") and file name (it had none)."""
    room = Path(path).parent.name.replace("_", " ")
    return f"A photo {spaces.in_scene(room) if room in spaces.SCENES else 'of ' + room}: {Path(path).name}"


def _library_grid(kind: str, names: str, show, note: str = "") -> None:
    """How many files the library holds, then a card per activity or room with its count and its
    first file (``show(path)`` plays or shows it)."""
    k = _KINDS[kind]
    counts = _library_counts(kind)
    n = counts[k["items"]]
    st.markdown(f"**{int(n.sum())} {k['items']}** for **{int((n > 0).sum())} of {len(k['names'])}** {names}.{note}")
    problem = _library_problem(kind, lab.library_stamp(kind))  # passed over in the counts, refused by training
    if problem:
        st.warning(f"Training the {kind} model would refuse this library: {problem}", icon=":material/folder_off:")
    cols = st.columns(3)
    for i, row in counts.iterrows():
        with cols[i % 3].container(border=True):
            name, count = row[k["label"]], row[k["items"]]
            st.markdown(f"**{i + 1}. {name}** · {app_support.counted(count, k['item'], k['items'])}")
            paths = k["paths"](name) if count else []
            if paths:
                show(paths[0])
            else:
                st.caption(f"No {k['item']} yet.")


sound_library, add_clip, scene_library, add_photo, train, tryit = st.tabs(
    ["Sound library", "Add clips", "Scene library", "Add photos", "Train and evaluate", "Try a clip or a photo"])

with sound_library:
    _library_grid("sound", "activities", lambda path: st.audio(str(path), format=lab.audio_mime(path)))
    # drawn only while open (as Results' tables): closed, its 40 players were sent on every run of the tab
    with st.expander("Every clip of one activity", key="lib-every-clip", on_change="rerun") as every_clip:
        if every_clip.open is not False:
            act = st.selectbox("Activity", spaces.ACTIVITIES, key="lib-activity", persist_state="page")
            every = clip_paths(act)
            for p in every[:40]:
                st.caption(p.name)
                st.audio(str(p), format=lab.audio_mime(p))
            if len(every) > 40:  # said, as for the photos (clips past the 40th were left out without a word)
                st.caption(f"The first 40 of {len(every)} clips, by file name.")

with add_clip:
    _add_tab("sound", "Add clips of one activity: WAV, FLAC or OGG, any sample rate (resampled to 32 kHz, "
                      "mixed to mono). Every file is checked before anything is added.")

with scene_library:
    _library_grid("scene", "rooms", lambda path: st.image(str(path), width=160, alt=_photo_alt(path)),
                  " In a study, the robot's camera \"sees\" one of the room's photos (the same one for the same "
                  "interaction): photos of the participant's own rooms make it real.")
    with st.expander("Every photo of one room", key="lib-every-photo", on_change="rerun") as every_photo:
        if every_photo.open is not False:  # drawn only while open, as the clips (48 photos)
            room = st.selectbox("Room", spaces.SCENES, key="lib-room", persist_state="page")
            photos = image_paths(room)[:48]
            # a row that wraps, of photos each as wide as keeps every name on one line: as many side by side as the
            # window holds (columns fitted to 1280 px broke "synthetic_0_00" / "0.jpg" at 1024; table_layouts.photo_width)
            width = table_layouts.photo_width(p.name for p in photos)
            with st.container(horizontal=True, gap="small", key="every-photo-grid"):
                for p in photos:
                    st.image(str(p), caption=p.name, width=width, alt=_photo_alt(p))
            if len(image_paths(room)) > len(photos):
                st.caption(f"The first {len(photos)} of {len(image_paths(room))} photos, by file name.")

with add_photo:
    _add_tab("scene", "Add photos of one room: JPEG, PNG, BMP or WebP, up to 89 megapixels (each is resized for the "
                      "model). Every file is checked before anything is added; a photo already in the library is "
                      "refused.")


def _metrics_view(metrics, kind: str) -> None:
    on = evaluated_on(metrics, "clips" if kind == "Sound" else "images")
    held_out = metrics.extra.get("set", "held-out") == "held-out"
    st.metric(f"{kind} {'test ' if held_out else ''}accuracy", f"{100 * metrics.accuracy:.1f}%", help=on)
    # not the figure the model was saved with, or held-out items taken by name only (walk3): said
    if not held_out or metrics.extra.get("held_out_missing") or metrics.extra.get("matched_by_name"):
        ui.noted("info", f"Accuracy {on}.")
    ui.chart(confusion_figure(metrics), width="content", key=f"cm-{kind}")
    per = metrics.per_class.rename(columns={"label": "class"})
    per = per.assign(accuracy=100 * per["accuracy"])  # whole percentages, as the rest of the page (it showed 66.67%)
    st.dataframe(per, hide_index=True, width="stretch", placeholder="–",  # a class with no item: "–", not "None"
                 column_config={"accuracy": st.column_config.NumberColumn(format="%.0f%%")})


def _previous_model_view(kind: str, busy: bool) -> None:
    """The model the last training replaced (kept beside the saved one): what it is, and a button
    that puts it back (the replaced model is kept in turn, so a second press undoes it)."""
    told = st.session_state.pop(f"put-back-{kind}", None)  # the last press's outcome, after its rerun
    if told is not None and told[0] == "ok":
        st.success(told[1], icon=":material/history:")
    elif told is not None:
        st.error(told[1], icon=":material/error:")
    kept = lab.kept_model(kind)
    if kept is None:
        return
    ui.noted("history", f"Kept beside it, to put back: {model_words(kept)}.")
    if st.button(f"Put back the previous {kind} model", key=f"btn-put-back-{kind}", disabled=busy,
                 icon=":material/undo:", help="It serves the tablets from their next interaction; the model "
                                              "saved now is kept in its place, so pressing again returns to it."):
        try:
            saved, replaced = lab.put_back_previous_model(kind, kept.get("model_id"))
        except CacasError as exc:
            st.session_state[f"put-back-{kind}"] = ("error", str(exc))
        else:
            st.session_state[f"put-back-{kind}"] = (
                "ok", f"The previous {kind} model is back ({model_words(saved)})"
                      + (f"; the one it replaced is kept ({model_words(replaced)})." if replaced else "."))
            for key in (f"train-{kind}", f"eval-{kind}"):  # their results were of the model put aside
                RUNNER.forget(key)
        st.rerun()


with train:
    running = app_support.open_days(ui.store())  # of every study: the recognisers serve them all
    if running:  # a model saved now serves the tablets from their next interaction on
        days = ", ".join(f"{p} (day {d})" for p, d in running.items())
        st.warning(f"Study days are open: {days}. A model trained or put back now is used on the tablet from "
                   "the next interaction on (each interaction records the id of the model that recognised it), "
                   "and training slows the tablet meanwhile: train between study days if you can.",
                   icon=":material/warning:")
    for kind, trainer, evaluator in (("Sound", lab.train_sound, lab.evaluate_sound),
                                     ("Scene", lab.train_scene, lab.evaluate_scene)):
        st.header(f"{kind} model", anchor=False)
        model = ui.recognizer(kind.lower())
        if model is None and ui.model_stamp(kind.lower()) is not None:  # saved, but cannot serve: say why
            try:
                lab.load_recognizer(kind.lower())
            except CacasError as exc:
                st.error(str(exc), icon=":material/error:")
        elif model is None:
            st.caption("No trained model saved yet.")
        else:
            meta = model.metadata
            data = meta.get("training_data", {})
            st.caption(f"Trained {app_support.short_time(meta.get('trained', '?'))} · test accuracy "
                       f"{100 * float(meta.get('accuracy', float('nan'))):.1f}% · "
                       f"{data.get('recordings', data.get('images', '?'))} items"
                       f"{app_support.synthetic_words(data)} · "
                       f"{meta.get('training_seconds', '?')} s · model id {model.model_id}")
            k = _KINDS[kind.lower()]
            now = int(_library_counts(kind.lower())[k["items"]].sum())
            then = data.get("recordings" if kind == "Sound" else "images")
            if then is not None and then != now:
                ui.noted("update", f"The {kind.lower()} library holds {now} {k['items']} now ({then} "
                                   "when this model was trained): train it again to use them.")
        key_train, key_eval = f"train-{kind.lower()}", f"eval-{kind.lower()}"
        busy = any(RUNNER.get(k) is not None and RUNNER.get(k).running for k in (key_train, key_eval))
        refused = _library_problem(kind.lower(), lab.library_stamp(kind.lower()))  # said before, not after a start
        if refused:
            st.warning(f"Cannot train the {kind.lower()} model on this library: {refused}",
                       icon=":material/folder_off:")
        c1, c2 = st.columns(2)
        took = (model.metadata.get("training_seconds") if model is not None else None)
        if c1.button(f"Train the {kind.lower()} model", disabled=busy or bool(refused), key=f"btn-{key_train}",
                     icon=":material/model_training:",
                     help=("Runs in the background; " + (f"the saved model took {float(took) / 60:.0f} min to train."
                                                         if took else "several minutes on 2 CPU cores.")
                           # lab walkthrough: one click replaced a 98.5 % model with an 18 % one, unsaid
                           + " The new model replaces the saved one when it is done, whatever its accuracy, and "
                             "the tablets use it from their next interaction; the replaced one is kept, and "
                             f"'Put back the previous {kind.lower()} model' returns to it.")):
            RUNNER.start(key_train, trainer, label=f"Training the {kind.lower()} model")
            st.rerun()
        if c2.button(f"Evaluate the saved {kind.lower()} model", disabled=busy or model is None,
                     key=f"btn-{key_eval}", icon=":material/fact_check:"):
            RUNNER.start(key_eval, evaluator, label=f"Evaluating the {kind.lower()} model")
            st.rerun()
        _previous_model_view(kind.lower(), busy)
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
        up = st.file_uploader("Clip", type=_KINDS["sound"]["types"], key="try-clip")
        rec = st.audio_input("Or record", key="try-record", sample_rate=32000)
        clip = up or rec
        if clip is not None:
            _recognise("sound", getattr(clip, "name", "recording.wav"), clip.getvalue())
    with c2:
        st.markdown("**A photo**")
        photo = st.file_uploader("Photo", type=_KINDS["scene"]["types"], key="try-photo")  # as the library takes
        if photo is not None:
            _recognise("scene", photo.name, photo.getvalue())

"""Overview: every participant's day, today's interactions, success rate so far, what to do next."""

import streamlit as st

from cacas import app_support, table_layouts
from cacas.recent_activity import recent_events
from cacas.study_day import STUDY_DAYS, TARGET_INTERACTIONS
from pages import ui

ui.require_app()


def recent_activity(events) -> None:
    """The study's latest events in words (``cacas.recent_activity.recent_events``)."""
    st.header("Recent activity", anchor=False)
    if events.empty:
        st.caption("Nothing recorded yet.")
        return
    # each time, "2 participants" and a code whole, "what" in the page's width (table_layouts.recent_activity_layout)
    widths, row_height = table_layouts.recent_activity_layout(events["participant"], events["what"])
    st.dataframe(events, hide_index=True, width="stretch", row_height=row_height,
                 column_config={c: st.column_config.TextColumn(c, width=w) for c, w in widths.items()})


store = ui.store()
study = ui.study()

st.title("Study overview", anchor=False)
st.caption(f"Study **{study}** · each participant runs {STUDY_DAYS} days of about {TARGET_INTERACTIONS} "
           "interactions with the robot; the robot is adapted after each day (Su & Sheng, Section V-B).")

table = app_support.overview_frame(store, study)
events = recent_events(store, limit=10, study=study)
if table.empty:
    st.info(f"No participants {'yet' if events.empty else 'now'}. Start on the **Participants** page: add a "
            "participant with a pseudonymous code and the 5 preferences they describe, or import a persona file.")
    ui.link("pages/participants.py", "Go to Participants", ":material/group:")
    if not events.empty:  # its last participant removed: the removal is said here too
        recent_activity(events)
    st.stop()

started = table["day"] != "not started"
row = ui.metric_row()
row.metric("Participants", len(table))
row.metric("Started", int(started.sum()))
row.metric("Interactions on open days", int(table["interactions today"].sum()),
          help="Interactions so far on the study days now open that count toward the ~15 a day: proposals "
               "answered and requests, as the success rate counts them (a closed day counts 0 here; unanswered "
               "ones are saved but not counted).")
rates = table["success rate so far"].dropna()
row.metric("Mean success rate so far", ui.percent(rates.mean()) if len(rates) else "–")

st.header("Participants", anchor=False)
small = st.column_config.TextColumn
# "next step" comes second, so that a narrower window (800 px beside the sidebar) scrolls the other columns, not
# what to do next (walkthrough: "Start day 2 on the tablet (Study sessi"); the age range is on Participants,
# today's count in the next step and the metric above. Every column in view at 1280 px, names whole
# (table_layouts.overview_table_layout: "last recorded" was cut at the right edge; a 16-character code whole)
shown = ["participant", "next step"] + [c for c in table.columns
                                        if c not in ("participant", "next step", "age range", "interactions today")]
widths, row_height = table_layouts.overview_table_layout(shown, table["participant"])
st.dataframe(
    table.assign(**{"success rate so far": 100 * table["success rate so far"]}), hide_index=True, width="stretch",
    column_order=shown, row_height=row_height, height=table_layouts.table_height(len(table), row_height),
    column_config={
        "participant": small("participant", width=widths["participant"]), "day": small("day", width=widths["day"]),
        "policy": small("policy", width=widths["policy"]),
        "last recorded": small("last recorded", width=widths["last recorded"],
                               help="When the participant's last interaction was recorded"),
        "success rate so far": st.column_config.ProgressColumn(
            "success rate so far", width=widths["success rate so far"], help="Robot-initiated actions the "
            "participant accepted, of the interactions so far that count: proposals answered and requests (Fig. 3; "
            "as in the paper, an unanswered proposal, the robot quiet with nothing asked, or a request while doing "
            "nothing (no sound activity, IV-C.1), is saved but not counted)",
            min_value=0.0, max_value=100.0, format="%.0f%%"),
        "next step": st.column_config.TextColumn("next step", width=widths["next step"]),
    })

code = ui.participant()
if code:
    row = table[table["participant"] == code]
    if len(row):
        st.header(f"Next for {code}", anchor=False)
        step = row["next step"].iloc[0]
        ui.noted("arrow_forward", f"**{step}**", caption=False)
        links = ui.metric_row()  # a link that does not fit goes on to the next line whole ("Open the study se")
        ui.link("pages/session.py", "Open the study session", ":material/tablet:", links)
        ui.link("pages/adaptation.py", "Adaptation", ":material/model_training:", links)
        ui.link("pages/results.py", "Results", ":material/monitoring:", links)

recent_activity(events)

"""Tidy tables shared by simulated and human studies: interactions and the daily metrics.

One definition of an interaction row and of the daily metrics serves ``cacas simulate`` and the
study database's export, so one set of plots reads both (design.md, the ``daily.csv`` contract).

Paper, Section V-B: "A successful event is defined as the robot initiates an action and the user
accepts it. Initiating an action by the user is not regarded as a successful event."
"If the user does not respond, the interaction is not recorded. When the user initiates an
action, two interaction data points are recorded".
"""

from __future__ import annotations

import numpy as np
import pandas as pd

#: Who started an interaction (Table II's conversation type).
ROBOT_INITIATED = "type_1"
USER_INITIATED = "type_2"

#: Columns of interactions.csv, in order (both simulated and human studies).
INTERACTION_COLUMNS = [
    "participant", "method", "day", "index", "time", "activity", "scene", "time_slot",
    "interval", "task", "previous_action", "previous_response", "type", "robot_action",
    "response", "user_action",
]

#: Columns of daily.csv, in order: design.md's contract first.
DAILY_COLUMNS = [
    "participant", "method", "day", "success_rate", "preference_accuracy",
    "cumulative_feedback", "interactions", "successes", "user_initiated", "feedback",
]


def feedback_points(interactions: pd.DataFrame) -> pd.Series:
    """User data points each interaction gives (Section V-B): a robot action answered with
    accept or reject gives 1; a user-initiated action gives 2 (the request accepted, "do
    nothing" rejected); no response, or the robot doing nothing unanswered, gives 0."""
    t1 = (interactions["type"] == ROBOT_INITIATED) & (interactions["robot_action"] != "do nothing") \
        & interactions["response"].isin(["accept", "reject"])
    t2 = interactions["type"] == USER_INITIATED
    return t1.astype(int) + 2 * t2.astype(int)


def is_success(interactions: pd.DataFrame) -> pd.Series:
    """The robot initiated an action (not "do nothing") and the participant accepted it."""
    return ((interactions["type"] == ROBOT_INITIATED) & (interactions["robot_action"] != "do nothing")
            & (interactions["response"] == "accept"))


def daily_table(interactions: pd.DataFrame, accuracy: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per participant, method and day: the daily.csv table.

    ``interactions`` has INTERACTION_COLUMNS; ``accuracy`` optionally has columns participant,
    method, day, preference_accuracy (the policy in force that day on the described
    preferences). Rows of ``accuracy`` with no interactions (a method not run in closed loop)
    get an empty success_rate and the cumulative feedback of the data that method adapted from.
    """
    keys = ["participant", "method", "day"]
    if len(interactions):
        df = interactions.assign(_success=is_success(interactions).astype(int),
                                 _points=feedback_points(interactions),
                                 _t2=(interactions["type"] == USER_INITIATED).astype(int))
        g = df.groupby(keys, sort=True)
        daily = pd.DataFrame({
            "interactions": g.size(),
            "successes": g["_success"].sum(),
            "user_initiated": g["_t2"].sum(),
            "feedback": g["_points"].sum(),
        }).reset_index()
        daily["success_rate"] = daily["successes"] / daily["interactions"]
        daily = daily.sort_values(keys)
        daily["cumulative_feedback"] = daily.groupby(["participant", "method"])["feedback"].cumsum()
    else:
        daily = pd.DataFrame(columns=keys + ["interactions", "successes", "user_initiated", "feedback",
                                             "success_rate", "cumulative_feedback"])
    if accuracy is not None and len(accuracy):
        daily = daily.merge(accuracy[keys + ["preference_accuracy"]], on=keys, how="outer")
    else:
        daily["preference_accuracy"] = np.nan
    return daily.sort_values(keys).reindex(columns=DAILY_COLUMNS).reset_index(drop=True)


def write_csv(df: pd.DataFrame, path) -> None:
    """CSV with fixed float formatting, so the same data gives the same bytes."""
    df.to_csv(path, index=False, float_format="%.6f", lineterminator="\n")

"""Plotly figures for context recognition (Section V-A): the confusion matrix and per-class accuracy."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

from cacas.recognition import Metrics


def confusion_figure(metrics: Metrics, normalise: bool = True, title: str | None = None) -> go.Figure:
    """Heat map of the confusion matrix (rows: true class, columns: predicted).

    With ``normalise`` each row is divided by its count (the per-class recall); the hover text
    shows the counts either way.
    """
    cm = np.asarray(metrics.confusion, dtype=float)
    rows = cm.sum(axis=1, keepdims=True)
    z = np.divide(cm, rows, out=np.zeros_like(cm), where=rows > 0) if normalise else cm
    labels = list(metrics.classes)
    text = [[f"true: {t}<br>predicted: {p}<br>count: {int(cm[i, j])}" for j, p in enumerate(labels)]
            for i, t in enumerate(labels)]
    fig = go.Figure(go.Heatmap(z=z, x=labels, y=labels, colorscale="Blues", zmin=0,
                               zmax=1 if normalise else None, hovertext=text, hoverinfo="text",
                               colorbar={"title": "share" if normalise else "count"}))
    size = max(420, 22 * len(labels) + 200)
    fig.update_layout(
        title=title or f"Confusion matrix (accuracy {metrics.accuracy:.1%}, n = {metrics.n})",
        xaxis={"title": "predicted", "tickangle": -60}, yaxis={"title": "true", "autorange": "reversed"},
        width=size, height=size, margin={"l": 160, "b": 160, "t": 60, "r": 20},
    )
    return fig


def per_class_figure(metrics: Metrics, title: str | None = None) -> go.Figure:
    """Bar chart of per-class accuracy (classes without test items are left out)."""
    pc = metrics.per_class.dropna(subset=["accuracy"])
    fig = go.Figure(go.Bar(x=pc["label"], y=pc["accuracy"], customdata=pc[["correct", "n"]].to_numpy(),
                           hovertemplate="%{x}: %{y:.0%} (%{customdata[0]}/%{customdata[1]})<extra></extra>"))
    fig.update_layout(title=title or "Per-class accuracy", yaxis={"range": [0, 1.05], "tickformat": ".0%"},
                      xaxis={"tickangle": -60}, margin={"b": 160})
    return fig

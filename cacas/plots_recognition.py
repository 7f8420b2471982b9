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


def confusion_png(metrics: Metrics, path, cell: int = 16) -> None:
    """Write the row-normalised confusion matrix as a PNG (Pillow only; for the README and reports)."""
    from PIL import Image, ImageDraw, ImageFont

    cm = np.asarray(metrics.confusion, dtype=float)
    rows = cm.sum(axis=1, keepdims=True)
    z = np.divide(cm, rows, out=np.zeros_like(cm), where=rows > 0)
    labels = list(metrics.classes)
    font = ImageFont.load_default()
    margin = 8 + max(int(ImageDraw.Draw(Image.new("RGB", (1, 1))).textlength(s, font=font)) for s in labels)
    k = len(labels)
    size = margin + k * cell + 10
    img = Image.new("RGB", (size, size + 24), "white")
    d = ImageDraw.Draw(img)
    d.text((4, 4), f"confusion matrix: accuracy {metrics.accuracy:.1%}, n = {metrics.n} (rows true, columns predicted)",
           fill="black", font=font)
    top = 24
    for i in range(k):
        d.text((4, top + margin + i * cell + 2), labels[i], fill="black", font=font)
        col = Image.new("RGB", (margin, cell), "white")
        ImageDraw.Draw(col).text((4, 2), labels[i], fill="black", font=font)
        img.paste(col.rotate(90, expand=True), (margin + i * cell, top))
        for j in range(k):
            v = z[i, j]
            shade = tuple(int(255 - v * (255 - c)) for c in (8, 48, 107))
            x0, y0 = margin + j * cell, top + margin + i * cell
            d.rectangle([x0, y0, x0 + cell - 1, y0 + cell - 1], fill=shade, outline=(225, 225, 225))
            if cm[i, j] and i != j:
                d.text((x0 + 4, y0 + 2), str(int(cm[i, j])), fill="red", font=font)
    img.save(path)

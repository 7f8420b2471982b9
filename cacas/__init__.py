"""CACAS Studio core library (Su & Sheng, "Context-Aware Conversation Adaptation for HRI").

Everything that computes or stores lives here; the Streamlit pages only call into it.
This package never imports streamlit.
"""

__version__ = "0.1.0"

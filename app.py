"""CACAS Studio: the study dashboard (``streamlit run app.py``)."""

import streamlit as st

st.set_page_config(page_title="CACAS Studio", page_icon=":robot_face:", layout="wide")
st.title("CACAS Studio")
st.markdown(
    "The study dashboard is being built. Coming next: participants and their preferences, "
    "the tablet study session, day-by-day adaptation, Fig. 3 / Fig. 4 results and the "
    "simulation lab. Meanwhile the `cacas` command line runs simulated studies."
)

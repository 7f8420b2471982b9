"""A small study day for tests: :func:`cough_day`. Import it into a test module: ``from studies import cough_day``."""


def cough_day(store, code: str = "P01", answers=(("pain check", "accept"),), hour: float = 8,
              interval_minutes: float = 5) -> int:
    """``code`` added to ``store`` with one described preference (a cough -> a pain check) and day 1 opened, on
    which a cough in the bedroom is answered once per ``answers`` ((robot action, response), ...); the day."""
    store.add_participant(code)
    store.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
    day = store.open_day(code)
    for robot_action, response in answers:
        store.record_interaction(code, day, activity="cough", scene="bedroom", hour=hour,
                                 interval_minutes=interval_minutes, robot_action=robot_action, response=response)
    return day

"""What the robot says, and what the participant asks for (the paper's language module, Fig. 2).

Two small jobs for the study's tablet page (Section V-B.1):

* :func:`robot_line` turns a recognised activity (S1) and the policy's action (S6, Table I) into a
  spoken-style line, e.g. ``robot_line("cough", "pain check")`` ->
  "I heard you coughing. Shall I check whether you are in pain?".
* :func:`match_request` maps a typed request ("can you remind me to switch the stove off?") to
  one of the 13 actions other than "do nothing", by keywords and synonyms. The paper's type_2
  interaction (Section IV-C.1): "the user intent is classified using NLU module. If the user
  intent belongs to one of the Agent Actions shown in Table I except *do nothing* ... the robot
  asks the user for confirmation". The page shows the match and asks the participant to confirm
  it; :func:`confirmation_line` is that question.

No model and no network: a keyword table, so that the behaviour is predictable in a study.
"""

from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass

from cacas import spaces
from cacas.errors import CacasError, shortened

# --- what the robot heard (S1) -------------------------------------------------------------------

#: "I heard ..." sentence per activity, in the paper's order.
HEARD: dict[str, str] = {
    "cough": "I heard you coughing.",
    "cry": "I heard you crying.",
    "clear throat": "I heard you clearing your throat.",
    "sneeze": "I heard you sneeze.",
    "sniff": "I heard you sniffing.",
    "fall down": "I heard something fall. Did you fall down?",
    "burp": "I heard a burp.",
    "yawn": "I heard you yawning.",
    "snore": "I heard you snoring.",
    "drink water": "I heard you drinking water.",
    "drink milk": "I heard you drinking milk.",
    "drink soup": "I heard you having soup.",
    "eat apple": "I heard you eating an apple.",
    "eat noodle": "I heard you eating noodles.",
    "eat chips": "I heard you eating chips.",
    "wash hands": "I heard you washing your hands.",
    "wash clothes": "I heard you washing clothes.",
    "wash dishes": "I heard you washing the dishes.",
    "use scissor": "I heard you using scissors.",
    "use blender": "I heard the blender.",
    "use stove": "I heard you using the stove.",
    "use hair dryer": "I heard the hair dryer.",
    "use microwave": "I heard the microwave.",
    "use fan": "I heard the fan.",
    "watch TV": "I heard the TV.",
    "type keyboard": "I heard you typing.",
    "cut food": "I heard you cutting food.",
    "fry food": "I heard something frying.",
    "pour water into glass": "I heard you pouring a glass of water.",
    "shave": "I heard you shaving.",
    "brush teeth": "I heard you brushing your teeth.",
    "flush toilet": "I heard the toilet flush.",
    "do nothing": "It is quiet here.",
}

#: The thing a reminder is about, per action and activity ("turn the stove off"); absent (a
#: policy may well remind someone crying to turn something off), the reminder is a general one
#: (:data:`GENERAL_REMINDERS`), never a dangling "it".
OBJECTS: dict[str, dict[str, str]] = {
    "remind to turn off": {
        "wash hands": "the tap", "wash dishes": "the tap", "wash clothes": "the washing machine",
        "use blender": "the blender", "use stove": "the stove", "fry food": "the stove",
        "use hair dryer": "the hair dryer", "use microwave": "the microwave", "use fan": "the fan",
        "watch TV": "the TV", "type keyboard": "the computer", "drink soup": "the stove",
        "eat noodle": "the stove", "pour water into glass": "the tap", "brush teeth": "the tap",
        "shave": "the razor"},
    "remind to unplug": {
        "wash clothes": "the washing machine", "use blender": "the blender",
        "use hair dryer": "the hair dryer", "use microwave": "the microwave", "use fan": "the fan",
        "watch TV": "the TV", "type keyboard": "the computer", "shave": "the razor"},
    "remind to put back": {
        "use scissor": "the scissors", "cut food": "the knife", "shave": "the razor",
        "brush teeth": "the toothbrush", "drink milk": "the milk", "eat chips": "the chips",
        "use hair dryer": "the hair dryer", "pour water into glass": "the glass",
        "drink soup": "the bowl", "eat noodle": "the bowl", "wash dishes": "the dishes"},
    "remind to be careful": {
        "use scissor": "the scissors", "cut food": "the knife", "shave": "the razor",
        "use stove": "the stove", "fry food": "the hot pan", "use blender": "the blender",
        "use hair dryer": "the hair dryer", "drink soup": "the hot soup", "fall down": "your steps",
        "use microwave": "hot food", "wash hands": "the wet floor"},
}
#: A reminder with no object for the activity, as the robot says it after "remind you to".
GENERAL_REMINDERS = {"remind to turn off": "switch off anything you left on",
                     "remind to unplug": "unplug anything you left plugged in",
                     "remind to put back": "put things back where they belong"}


def _object(action: str, activity: str) -> str | None:
    act = spaces.canonical("action", action)
    return OBJECTS.get(act, {}).get(spaces.canonical("activity", activity))


# --- what the robot offers (S6) ------------------------------------------------------------------

#: The robot's offer per action; ``{obj}`` is the activity's object or "it".
OFFERS: dict[str, str] = {
    "do nothing": "",
    "show compassion": "I'm sorry. Would you like some company? I'm here with you.",
    "chitchat": "Would you like to chat for a while?",
    "remind to take medicine": "Shall I remind you to take your medicine?",
    "ask to offer help": "Can I help you with anything?",
    "call someone for help": "Shall I call someone to help you?",
    "set a timer": "Shall I set a timer for you?",
    "pain check": "Shall I check whether you are in pain?",
    "confirm sound": "Did I hear that right?",
    "record sound": "Shall I record this sound?",
    "remind to turn off": "Shall I remind you to turn {obj} off?",
    "remind to be careful": "Please be careful{with_obj}. Shall I keep reminding you?",
    "remind to put back": "Shall I remind you to put {obj} back?",
    "remind to unplug": "Shall I remind you to unplug {obj}?",
}

#: What the participant asks for, in their words (the tablet's "Ask the robot" list).
REQUESTS: dict[str, str] = {
    "show compassion": "Comfort me",
    "chitchat": "Chat with me",
    "remind to take medicine": "Remind me to take my medicine",
    "ask to offer help": "Help me with something",
    "call someone for help": "Call someone for help",
    "set a timer": "Set a timer",
    "pain check": "Check whether I am in pain",
    "confirm sound": "Confirm what you heard",
    "record sound": "Record this sound",
    "remind to turn off": "Remind me to turn it off",
    "remind to be careful": "Remind me to be careful",
    "remind to put back": "Remind me to put it back",
    "remind to unplug": "Remind me to unplug it",
}

QUIET_LINE = "(The robot stays quiet.)"


def request_words(action: str) -> str:
    """A request in the participant's words inside a sentence: "check whether I am in pain" for
    "pain check" (the REQUESTS phrase with its first letter lower-cased; unknown name: CacasError)."""
    words = REQUESTS[spaces.canonical("action", action)]
    return words[0].lower() + words[1:]


def heard_line(activity: str) -> str:
    """What the robot says it heard, e.g. "I heard you coughing." (unknown name: CacasError)."""
    return HEARD[spaces.canonical("activity", activity)]


def offer_line(action: str, activity: str = "do nothing") -> str:
    """The robot's offer for ``action`` about ``activity``; "" for "do nothing"."""
    act = spaces.canonical("action", action)
    obj = _object(act, activity)
    if obj is None and act in GENERAL_REMINDERS:
        return f"Shall I remind you to {GENERAL_REMINDERS[act]}?"
    return OFFERS[act].format(obj=obj, with_obj=f" with {obj}" if obj else "")


def robot_line(activity: str, action: str) -> str:
    """The spoken-style line for the robot proposing ``action`` after hearing ``activity``.

    "do nothing" gives :data:`QUIET_LINE`: the robot does not speak, and the participant may ask
    for something themselves (type_2).
    """
    act = spaces.canonical("action", action)
    if act == "do nothing":
        return QUIET_LINE
    heard = heard_line(activity)
    offer = offer_line(act, activity)
    if spaces.canonical("activity", activity) == "do nothing":
        return offer
    return f"{heard} {offer}"


def request_label(action: str) -> str:
    """The participant's words for asking for ``action`` ("do nothing" is not a request)."""
    act = spaces.canonical("action", action)
    if act not in REQUESTS:
        raise CacasError(f"{act!r} cannot be requested; valid: {', '.join(REQUESTS)}")
    return REQUESTS[act]


def confirmation_line(action: str, activity: str = "do nothing", text: str | None = None) -> str:
    """The robot's confirmation question for a matched request (Section IV-C.1). A reminder is
    about what the typed request ``text`` names ("turn off the TV": the TV, whatever activity was
    heard), else about the activity's object (:data:`OBJECTS`)."""
    named = typed_object(text, action) if text else None
    return f"You would like me to {_infinitive(action, activity, named)}. Is that right?"


def typed_object(text: str, action: str) -> str | None:
    """The object of :data:`OBJECTS` for ``action`` that a typed request names ("the TV" in
    "please turn off the tv"), the longest one if several; None if it names none."""
    act = spaces.canonical("action", action)
    low = _folded(str(text))
    for obj in sorted(dict.fromkeys(OBJECTS.get(act, {}).values()), key=len, reverse=True):
        noun = re.sub(r"^(the|your) ", "", obj).lower()
        if re.search(rf"\b{re.escape(noun)}\b", low):
            return obj
    return None


def _infinitive(action: str, activity: str, obj: str | None = None) -> str:
    act = spaces.canonical("action", action)
    obj = obj or _object(act, activity)
    if obj is None and act in GENERAL_REMINDERS:
        return f"remind you to {GENERAL_REMINDERS[act]}"
    return {
        "show compassion": "keep you company for a moment",
        "chitchat": "chat with you",
        "remind to take medicine": "remind you to take your medicine",
        "ask to offer help": "help you",
        "call someone for help": "call someone for help",
        "set a timer": "set a timer",
        "pain check": "check whether you are in pain",
        "confirm sound": "confirm what I heard",
        "record sound": "record this sound",
        "remind to turn off": f"remind you to turn {obj} off",
        "remind to be careful": f"remind you to be careful{f' with {obj}' if obj else ''}",
        "remind to put back": f"remind you to put {obj} back",
        "remind to unplug": f"remind you to unplug {obj}",
    }[act] if act != "do nothing" else "do nothing"


# --- matching a typed request --------------------------------------------------------------------

#: Keywords and phrases per requestable action; a phrase of n words counts n points.
SYNONYMS: dict[str, tuple[str, ...]] = {
    "show compassion": ("compassion", "comfort", "console", "sympathy", "sad", "upset", "lonely",
                        "cheer me up", "feel bad", "feeling down", "hug", "company", "unhappy",
                        "stay with me", "miserable", "depressed"),
    "chitchat": ("chat", "chitchat", "talk", "conversation", "bored", "joke", "story", "tell me a joke", "tell me a story",
                 "keep me company talking", "small talk", "gossip", "news"),
    "remind to take medicine": ("medicine", "medication", "meds", "pill", "pills", "drug", "dose",
                                "prescription", "vitamin", "vitamins", "insulin", "inhaler",
                                "take medicine", "take my medicine"),
    "ask to offer help": ("help", "assist", "assistance", "hand me", "give me a hand", "support",
                          "help me", "need help", "do something for me", "fetch",
                          "bring", "get me", "tea", "coffee", "a drink", "cup of"),
    "call someone for help": ("call", "phone", "ring", "emergency", "ambulance", "doctor", "nurse",
                              "family", "someone", "somebody", "911", "contact", "daughter", "son",
                              "caregiver", "neighbour", "neighbor", "call for help",
                              "call someone", "call my",
                              # a fall, said as it is (walkthrough: "I fell" was not understood)
                              "fell", "fallen", "i fell", "i have fallen", "i've fallen", "fell down",
                              "can't get up", "cannot get up", "cant get up", "on the floor"),
    "set a timer": ("timer", "alarm", "countdown", "stopwatch", "set a timer", "time it",
                    "minutes", "remind me in", "wake me"),
    "pain check": ("pain", "hurt", "hurts", "ache", "aches", "injured", "injury", "sore",
                   "check on me", "am i ok", "am i okay", "pain check", "check my pain", "wound",
                   "bleeding", "dizzy"),
    "confirm sound": ("confirm", "what was that", "what did you hear", "did you hear",
                      "recognise", "recognize", "identify", "which sound", "what sound",
                      "confirm sound", "hear that"),
    "record sound": ("record", "recording", "save the sound", "capture", "save this sound",
                     "record sound", "record this"),
    "remind to turn off": ("turn off", "switch off", "shut off", "turn it off", "switch it off",
                           "power off", "off", "stove off", "shut down", "switch it off"),
    "remind to be careful": ("careful", "caution", "cautious", "safe", "safely", "slippery",
                             "watch out", "be careful", "look out", "mind", "sharp", "hot", "knife"),
    "remind to put back": ("put back", "put away", "put it back", "put them back", "return",
                           "tidy", "tidy up", "back in place", "where it belongs", "store",
                           "clean up", "away", "back"),
    "remind to unplug": ("unplug", "plug", "socket", "outlet", "cord", "cable", "pull the plug",
                         "unplug it", "plugged"),
}

_WORD = re.compile(r"[a-z0-9']+")
#: Punctuation that ends a clause: a negation before it does not reach the words after it ("No, call my
#: daughter", "Stop! Call an ambulance" ask for the call).
_CLAUSE_END = re.compile(r"[.,;:!?]")
#: One pass over the text: a word, or a clause's end (the two never overlap).
_TOKEN = re.compile(rf"({_WORD.pattern})|{_CLAUSE_END.pattern}")


def _quoted(text: str) -> str:
    """``text`` quoted in an English sentence (as repr quotes it); text of a right-to-left script (Arabic, Hebrew) is
    isolated in it (Unicode's first-strong isolate, U+2068 ... U+2069), so that it reads from the right within the
    quotes: its closing "!" or emoji stood at its right, where an Arabic sentence starts, and a line break split the
    quotes from it (the tablet in Chromium)."""
    if not any(unicodedata.bidirectional(c) in ("R", "AL") for c in text):
        return repr(text)
    mark = '"' if "'" in text else "'"
    return f"{mark}\u2068{text}\u2069{mark}"


def _folded(text: str) -> str:
    """``text`` lower case, as the keywords are written: full-width letters as theirs ("ＴＩＭＥＲ", a Japanese
    keyboard's), accents off ("café"), and Turkish capital "İ" as "i" (a Turkish keyboard's capital i: "TİMER" was
    "ti̇mer", no keyword), "’" as "'". Only for matching: the request is shown as typed."""
    decomposed = unicodedata.normalize("NFKD", text.lower().replace("’", "'"))
    return "".join(c for c in decomposed if not unicodedata.combining(c))


def _tokens(text: str) -> tuple[list[str], list[int]]:
    """The words of ``text`` (:func:`_folded`) and the clause (0, 1, ...) of each, clauses
    ending at :data:`_CLAUSE_END`: one tokeniser for both (they were two, and had to agree)."""
    words: list[str] = []
    clauses: list[int] = []
    clause = 0
    for token in _TOKEN.finditer(_folded(text)):
        if token.group(1) is None:
            clause += 1
        else:
            words.append(token.group(1))
            clauses.append(clause)
    return words, clauses


def _words(text: str) -> list[str]:
    return _tokens(text)[0]


#: Particles of phrasal verbs that take their object in between: "put the knife back", "turn the oven off".
_PARTICLES = {"back", "away", "off", "on", "out", "up", "down"}
#: How many words may stand between such a verb and its particle.
_PARTICLE_REACH = 4


def _positions(words: list[str], phrase: tuple[str, ...]) -> set[int]:
    """Word positions of every occurrence of ``phrase`` in ``words``; a verb and its particle
    ("put back", "turn off") also with up to :data:`_PARTICLE_REACH` words between them, the
    object's ("put the knife back" was taken for "remind to be careful" by its knife alone)."""
    n = len(phrase)
    found = {i + k for i in range(len(words) - n + 1) if tuple(words[i:i + n]) == phrase for k in range(n)}
    if n == 2 and phrase[1] in _PARTICLES:
        for i, w in enumerate(words):
            if w == phrase[0]:
                j = next((j for j in range(i + 2, min(len(words), i + 2 + _PARTICLE_REACH)) if words[j] == phrase[1]),
                         None)
                if j is not None:
                    found.update((i, j))
    return found


_PHRASES: dict[str, list[tuple[str, ...]]] = {
    act: sorted({tuple(_words(p)) for p in (*syn, act)}, key=len, reverse=True)
    for act, syn in SYNONYMS.items()
}


@dataclass(frozen=True)
class RequestMatch:
    """The best action for a typed request, its score and the words that matched.

    ``alternatives`` lists the other actions that matched, best first, as (action, score).
    """

    text: str
    action: str
    score: int
    matched: tuple[str, ...]
    alternatives: tuple[tuple[str, int], ...] = ()


def score_request(text: str) -> list[tuple[str, int, tuple[str, ...]]]:
    """Every requestable action with a positive score for ``text``, best first.

    An action's score is the number of words of the text that its keywords and phrases cover
    (so "turn off" scores 2, and "off" inside it adds nothing). Ties keep Table I's order.
    """
    words = _words(text)
    out = []
    for order, act in enumerate(SYNONYMS):
        covered: set[int] = set()
        hits = []
        for p in _PHRASES[act]:
            at = _positions(words, p)
            if at:
                hits.append(" ".join(p))
                covered.update(at)
        score = len(covered)
        if score:
            out.append((act, score, tuple(hits), order))
    out.sort(key=lambda r: (-r[1], r[3]))
    return [(a, s, h) for a, s, h, _ in out]


#: Typed words that ask for nothing ("nothing needed", "leave me alone", "no thanks").
_NOTHING_WANTED = re.compile(r"\b(nothing|leave me( alone)?|no,? thanks?|no thank you|go away|not now|never ?mind)\b",
                             re.I)
#: "Never mind" asks for nothing: its "mind" is not "remind to be careful"'s ("mind the step"); it is
#: taken out before matching, a clause's end in its place ("never mind, call my son" asks for the call)
_NEVER_MIND = re.compile(r"\bnever ?mind\b", re.I)


#: Words that turn a request into its opposite when they come before the action's words ("don't call")
_NEGATIONS = {"don't", "dont", "not", "never", "no", "nothing", "stop", "without", "won't", "shouldn't", "mustn't"}
#: Words that may stand between such a word and the action's ("no need to call", "do not want a timer");
#: any other word ends its reach ("I'm not well, call for help" asks for help)
_NEGATION_REACH = {"to", "me", "you", "it", "want", "need", "please", "a", "an", "the", "any", "anyone", "do",
                   "dare", "ever", "bother", "more", "again", "with",
                   # request verbs not among an action's own words ("do not remind me to turn off the stove")
                   "remind", "reminding", "tell", "ask", "keep", "show", "offer", "talk", "chat", "play", "set"}


def _negated(text: str, action: str) -> bool:
    """Whether a negation governs the words that matched ``action``: "don't call anyone", "no need to
    call", "I do not want a timer", "stop the chitchat". "Don't forget to remind me" is a request, and
    so is "No, call my daughter": a negation does not reach past the end of its clause."""
    words, clause = _tokens(text)
    first = min(i for p in _PHRASES[action] for i in _positions(words, p))
    for i in range(first - 1, -1, -1):
        if clause[i] != clause[first]:
            return False
        if words[i] in _NEGATIONS:
            return not (i + 1 < len(words) and words[i + 1] == "forget")
        if words[i] not in _NEGATION_REACH:
            return False
    return False


def match_request(text: str) -> RequestMatch:
    """Match a typed request to one of the 13 actions other than "do nothing".

    Empty text, or text that matches no action, raises CacasError with examples of what the
    robot understands; the page shows it in place and the participant can pick from the list.
    """
    if not isinstance(text, str) or not text.strip():
        raise CacasError("The request is empty. Type what you would like the robot to do, "
                         "for example 'remind me to turn off the stove'.")
    said = _NEVER_MIND.sub(",", text)
    ranked = score_request(said)
    if not ranked:
        if _NOTHING_WANTED.search(text):  # not a request: there is an answer for it
            raise CacasError("All right, nothing then. Press 'Reject' if the robot offered something you do not "
                             "want, or 'Nothing needed' if it stayed quiet.")
        examples = " or ".join(f"'{request_words(a)}'" for a in ("pain check", "set a timer"))
        said = text.strip()
        said = shortened(said, 60)  # a long text is not echoed whole
        raise CacasError(f"Sorry, the robot did not understand {_quoted(said)}. Try other words, for example "
                         f"{examples}, or pick what you would like from the list above.")
    best, score, hits = ranked[0]
    if _negated(said, best):  # "please don't call anyone" asks for the opposite of "call someone for help"
        raise CacasError(f"All right, not that ('{request_words(best)}'). Press 'Reject' if the robot offered "
                         "something you do not want, or pick what you would like from the list above.")
    return RequestMatch(text=text.strip(), action=best, score=score, matched=hits,
                        alternatives=tuple((a, s) for a, s, _ in ranked[1:]))

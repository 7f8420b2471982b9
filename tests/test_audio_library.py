"""The sound library: slugs, the synthetic generator, clip_paths, scan and the importer."""

import numpy as np
import pytest
import soundfile as sf

from cacas import spaces
from cacas.audio import library, synth
from cacas.errors import CacasError


def test_slugs_round_trip_every_activity():
    for name in spaces.ACTIVITIES:
        s = library.activity_slug(name)
        assert s.replace("_", "").isalnum() and s == s.lower()
        assert library.activity_of_folder(s) == name
    assert library.activity_slug("Watch TV") == "watch_tv"
    with pytest.raises(CacasError):
        library.activity_of_folder("make_coffee")


def test_every_activity_renders_a_distinct_plausible_clip():
    rng = np.random.default_rng(0)
    rms = {}
    for name in spaces.ACTIVITIES:
        y = synth.render(name, rng, seconds=1.0)
        assert y.dtype == np.float32 and y.shape == (32000,) and np.all(np.isfinite(y))
        assert np.max(np.abs(y)) <= 0.99
        rms[name] = float(np.sqrt(np.mean(y ** 2)))
    assert rms["do nothing"] < 0.01 < min(v for k, v in rms.items() if k != "do nothing")


def test_render_is_reproducible_and_varied():
    a = synth.render("cough", np.random.default_rng([1, 2]), 1.0)
    b = synth.render("cough", np.random.default_rng([1, 2]), 1.0)
    c = synth.render("cough", np.random.default_rng([1, 3]), 1.0)
    assert np.array_equal(a, b) and not np.allclose(a, c)


def test_generate_and_clip_paths(tmp_path):
    paths = library.generate_library(2, seconds=1.0, root=tmp_path, activities=["watch TV", "cough"])
    assert len(paths) == 4
    clips = library.clip_paths("Watch tv", root=tmp_path)
    assert [p.parent.name for p in clips] == ["watch_tv", "watch_tv"] and clips[0].suffix == ".ogg"
    assert library.clip_paths("sneeze", root=tmp_path) == []
    found = library.scan(tmp_path)
    assert [c.activity for c in found] == ["cough", "cough", "watch TV", "watch TV"]


def test_clips_are_encoded_into_files_not_file_objects(tmp_path, monkeypatch):
    """soundfile reads and writes a file object (a BytesIO) through cffi callbacks, and cffi swallows
    an exception raised in one: a Ctrl-C that arrived while a clip was encoded was printed as
    "Exception ignored from cffi callback" and the generate went on to place its clips (CLI audit,
    2 of 3 tries). Every clip is encoded into, and read back from, a file path that libsndfile opens
    itself, and the generate still writes the same clips (compared with a second seed-0 run)."""
    import soundfile

    given = []
    for verb in ("write", "read"):
        real = getattr(soundfile, verb)
        monkeypatch.setattr(soundfile, verb,
                            lambda file, *a, _real=real, **k: given.append(file) or _real(file, *a, **k))
    paths = library.generate_library(1, seconds=1.0, root=tmp_path, activities=["cough", "snore"])
    again = library.generate_library(1, seconds=1.0, root=tmp_path, activities=["cough", "snore"])
    assert paths.written == 2 and again.unchanged == paths  # read back and compared with the clips written
    # a path: text, or the file system's bytes (features.libsndfile_path), never a file object
    assert len(given) >= 6 and all(isinstance(f, (str, bytes)) for f in given), [type(f).__name__ for f in given]


def test_generating_a_seed_again_leaves_its_clips_bytes_alone(tmp_path):
    """The OGG encoder stamps a random serial number: without the check, the same audio would be
    written with other bytes (the shipped clips showed as modified in git). A clip whose audio
    changed, or an unreadable one, is rewritten with ``replace`` (below: refused without it)."""
    paths = library.generate_library(2, seconds=1.0, root=tmp_path, activities=["cough"])
    before = [p.read_bytes() for p in paths]
    again = library.generate_library(2, seconds=1.0, root=tmp_path, activities=["cough"])
    assert paths.unchanged == [] and paths.written == 2
    assert again == paths and again.replaced == [] and again.unchanged == paths and again.written == 0
    assert [p.read_bytes() for p in paths] == before
    paths[0].write_bytes(b"not audio")
    # other audio: longer clips
    assert library.generate_library(2, seconds=2.0, root=tmp_path, activities=["cough"], replace=True).replaced == paths
    assert len(library.load_clip(paths[0])) == 2 * library.SAMPLE_RATE and paths[1].read_bytes() != before[1]


def test_generating_other_clips_under_the_names_of_the_librarys_is_refused_without_replace(tmp_path):
    """CLI audit: `cacas sound generate --seconds 1` (seed 0) replaced the shipped 2-s clips of the
    same names with 1-s ones without a word ("66 synthetic clips of seed 0 ..."), and `--format
    flac` put each shipped clip in the library twice (the .ogg and a .flac of the same audio, which
    a held-out split could put on both sides). Both are refused, naming the file, what it holds and
    the ways on, and nothing is written; with ``replace`` they are replaced (the other format's
    removed) and said."""
    shipped = library.generate_library(2, seconds=2.0, root=tmp_path, activities=["cough", "sneeze"])
    library.generate_library(1, seconds=2.0, seed=1, root=tmp_path, activities=["cough"])

    def tree():
        return {p.relative_to(tmp_path).as_posix(): p.read_bytes() for p in sorted(tmp_path.rglob("*")) if p.is_file()}

    before = tree()
    with pytest.raises(CacasError) as err:
        library.generate_library(2, seconds=1.0, root=tmp_path, activities=["cough", "sneeze"])
    assert str(err.value) == (
        f"{shipped[0]}: holds other audio than this run writes there (a 2-s clip; this run's: 1 s); a run of seed 0 "
        "writes its clips under these names and would replace the library's (the shipped ones, or an earlier "
        "run's); valid: --seed 2 for new clips beside them, --out DIR for a library of its own, or --replace to "
        "replace them; nothing was written")
    with pytest.raises(CacasError, match=r"cough/synthetic_0_000\.ogg: holds the clip this run writes as "
                                         r"synthetic_0_000\.flac, in another format \(the library would hold it "
                                         r"twice\); .*nothing was written$"):
        library.generate_library(2, seconds=2.0, root=tmp_path, activities=["cough", "sneeze"], fmt="flac")
    assert tree() == before
    done = library.generate_library(2, seconds=1.0, root=tmp_path, activities=["cough", "sneeze"], replace=True)
    assert done == done.replaced == shipped and done.removed == []
    assert all(len(library.load_clip(p)) == library.SAMPLE_RATE for p in shipped)
    flac = library.generate_library(2, seconds=1.0, root=tmp_path, activities=["cough", "sneeze"], fmt="flac",
                                    replace=True)
    assert flac.replaced == [] and flac.removed == shipped and not any(p.exists() for p in shipped)
    assert len(library.scan(tmp_path)) == 5  # 2 x 2 clips of seed 0, once each, and seed 1's


def test_generate_refuses_bad_arguments(tmp_path):
    with pytest.raises(CacasError):
        library.generate_library(0, root=tmp_path)
    with pytest.raises(CacasError):
        library.generate_library(1, seconds=0.2, root=tmp_path)
    with pytest.raises(CacasError, match="^unknown clip format 'mp3'; valid: ogg, flac, wav$"):
        library.generate_library(1, fmt="MP3", root=tmp_path)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("replace", [False, True])
def test_a_folder_where_a_clip_goes_is_refused_as_a_folder(tmp_path, replace):
    """CLI audit: a folder named like a clip was said to hold "a file that cannot be read as audio",
    and --replace was offered, which cannot replace a folder."""
    (tmp_path / "snore" / "synthetic_0_001.ogg").mkdir(parents=True)
    with pytest.raises(CacasError, match=rf"^{tmp_path / 'snore' / 'synthetic_0_001.ogg'}: a folder, where this run "
                                         r"writes a clip; valid: move or rename that folder, or --out DIR for a "
                                         r"library of its own; nothing was written$"):
        library.generate_library(2, seconds=1.0, root=tmp_path, activities=["cough", "snore"], replace=replace)
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")) == ["snore",
                                                                                      "snore/synthetic_0_001.ogg"]


def test_shipped_library_covers_every_activity_and_stays_small():
    for name in spaces.ACTIVITIES:
        assert len(library.clip_paths(name)) >= 10, name
    n, size = library.library_clips()
    assert n == sum(len(library.clip_paths(a)) for a in spaces.ACTIVITIES) and size < 20_000_000


def _researcher_folder(tmp_path):
    src = tmp_path / "mine"
    (src / "cough").mkdir(parents=True)
    (src / "Watch TV").mkdir()
    t = np.arange(48000) / 48000
    sf.write(src / "cough" / "c1.flac", np.stack([0.3 * np.sin(2 * np.pi * 300 * t)] * 2, 1), 48000)
    sf.write(src / "Watch TV" / "tv.wav", 0.2 * np.sin(2 * np.pi * 200 * t[:16000]), 16000, subtype="PCM_U8")
    return src


def _other_clips(src):
    """Other recordings under the same names."""
    t = np.arange(16000) / 16000
    sf.write(src / "cough" / "c1.flac", 0.3 * np.sin(2 * np.pi * 500 * t), 16000)
    sf.write(src / "Watch TV" / "tv.wav", 0.3 * np.sin(2 * np.pi * 700 * t), 16000)


def test_import_folder_copies_checked_recordings(tmp_path):
    src = _researcher_folder(tmp_path)
    lib = tmp_path / "lib"
    copied = library.import_folder(src, root=lib)
    assert sorted(p.relative_to(lib).as_posix() for p in copied) == ["cough/c1.flac", "watch_tv/tv.wav"]
    with pytest.raises(CacasError, match=r"tv\.wav: the same clip is already in the library as "
                                          r"watch_tv/tv\.wav; nothing was imported"):
        library.import_folder(src, root=lib)  # the same clips again: copies would flatter a model's test
    assert len(library.scan(lib)) == 2
    _other_clips(src)
    again = library.import_folder(src, root=lib)  # same names: kept apart, not overwritten
    assert sorted(p.name for p in again) == ["imported_1_c1.flac", "imported_1_tv.wav"]


def test_import_refuses_a_clip_given_twice_under_two_names(tmp_path):
    src = _researcher_folder(tmp_path)
    (src / "sneeze").mkdir()
    (src / "sneeze" / "s.flac").write_bytes((src / "cough" / "c1.flac").read_bytes())
    with pytest.raises(CacasError, match=r"s\.flac: the same clip is given twice \(also as c1\.flac\)"):
        library.import_folder(src, root=tmp_path / "lib")
    assert not (tmp_path / "lib").exists() or not library.scan(tmp_path / "lib")


def test_import_refuses_bad_folder_name_and_copies_nothing(tmp_path):
    src = _researcher_folder(tmp_path)
    (src / "make_coffee").mkdir()
    lib = tmp_path / "lib"
    with pytest.raises(CacasError, match="make_coffee"):
        library.import_folder(src, root=lib)
    assert not lib.exists()


def test_import_refuses_a_bad_file_and_copies_nothing(tmp_path):
    src = _researcher_folder(tmp_path)
    (src / "cough" / "broken.wav").write_text("not audio")
    lib = tmp_path / "lib"
    with pytest.raises(CacasError, match="broken.wav"):
        library.import_folder(src, root=lib)
    assert not lib.exists()
    with pytest.raises(CacasError, match=r"absent: no such folder; expected <folder>/<activity>/<clip>"
                                         r"\.wav\|\.flac\|\.ogg$"):
        library.import_folder(tmp_path / "absent", root=lib)


def test_import_refuses_an_unsupported_file_naming_it_and_the_valid_types(tmp_path):
    src = _researcher_folder(tmp_path)
    (src / "cough" / "notes.txt").write_text("recorded on Monday")
    lib = tmp_path / "lib"
    with pytest.raises(CacasError, match=r"notes\.txt: unsupported file type '\.txt'; valid: \.wav, \.flac, \.ogg$"):
        library.import_folder(src, root=lib)
    assert not lib.exists()
    (src / "cough" / "notes.txt").unlink()
    (src / "stray.wav").write_bytes((src / "cough" / "c1.flac").read_bytes())  # beside the activity folders
    with pytest.raises(CacasError, match=r"stray\.wav: not in an activity folder; expected <folder>/<activity>/"):
        library.import_folder(src, root=lib)
    assert not lib.exists()


def test_import_of_a_folder_with_no_recording_is_refused(tmp_path):
    src = tmp_path / "mine"
    (src / "cough").mkdir(parents=True)
    (src / "cough" / ".DS_Store").write_bytes(b"x")  # hidden files are not recordings
    with pytest.raises(CacasError, match=r"mine: no clips found; expected <folder>/<activity>/<clip>"):
        library.import_folder(src, root=tmp_path / "lib")
    with pytest.raises(CacasError, match="no clips found"):
        library.import_folder(tmp_path / "mine" / "cough", root=tmp_path / "lib")  # nothing inside: not usable


def test_import_that_fails_part_way_leaves_the_library_as_it_was(tmp_path, monkeypatch, fail_on_call):
    import shutil

    from cacas import media_library

    src = _researcher_folder(tmp_path)
    lib = tmp_path / "lib"
    first = library.import_folder(src, root=lib)
    before = sorted(p.relative_to(lib).as_posix() for p in lib.rglob("*"))
    _other_clips(src)
    copy = fail_on_call(shutil.copyfile, 2)
    monkeypatch.setattr(media_library.shutil, "copyfile", copy)
    with pytest.raises(CacasError, match="No space left on device.*nothing was imported"):
        library.import_folder(src, root=lib)
    monkeypatch.undo()
    assert len(copy.calls) == 2 and sorted(p.relative_to(lib).as_posix() for p in lib.rglob("*")) == before
    assert sorted(library.clip_paths("cough", lib) + library.clip_paths("watch TV", lib)) == sorted(first)


def test_scan_refuses_what_it_cannot_read_and_leaves_notes_beside_the_folders(tmp_path):
    library.generate_library(1, seconds=1.0, root=tmp_path, activities=["sneeze", "cough"])
    (tmp_path / "README.md").write_text("about this library")  # beside the folders: left alone
    assert [c.activity for c in library.scan(tmp_path)] == ["cough", "sneeze"]  # Table I order
    (tmp_path / "cough" / "notes.txt").write_text("x")
    with pytest.raises(CacasError, match=r"cough/notes\.txt: unsupported file type '\.txt'; valid: \.wav"):
        library.scan(tmp_path)
    (tmp_path / "cough" / "notes.txt").unlink()
    (tmp_path / "make_coffee").mkdir()
    with pytest.raises(CacasError, match=r"folder name 'make_coffee' is not an activity; valid: .*watch_tv"):
        library.scan(tmp_path)
    (tmp_path / "make_coffee").rmdir()
    (tmp_path / "cutting_food").mkdir()  # what someone is doing, for a two-word activity: named as a folder is
    with pytest.raises(CacasError, match=r"folder name 'cutting_food' is not an activity; did you mean 'cut_food'\? "):
        library.scan(tmp_path)
    with pytest.raises(CacasError, match=r"absent: no such sound folder; expected <folder>/<activity>/<clip>"):
        library.scan(tmp_path / "absent")


def test_files_with_extensions_lists_only_matching_files_of_the_folder(tmp_path):
    from cacas.media_library import files_with_extensions

    assert library.files_with_extensions is files_with_extensions  # the one the scene library uses too
    for name in ("b.WAV", "a.ogg", "notes.txt"):
        (tmp_path / name).write_bytes(b"x")
    (tmp_path / "sub.wav").mkdir()
    assert [p.name for p in library.files_with_extensions(tmp_path, (".wav", ".ogg"))] == ["a.ogg", "b.WAV"]
    assert library.files_with_extensions(tmp_path / "missing", (".wav",)) == []


def test_import_refuses_a_clip_shorter_than_half_a_second_and_copies_nothing(tmp_path):
    """Review: a 0.2-s clip went into the library without a word (the model hears 1-s windows: it
    would train on the padding), while 'Try a clip' flags one. Half a second or more is taken."""
    src = _researcher_folder(tmp_path)
    rng = np.random.default_rng(0)
    sf.write(src / "cough" / "short.wav", 0.3 * rng.standard_normal(int(0.2 * 32000)).astype(np.float32), 32000)
    sf.write(src / "cough" / "half.wav", 0.3 * rng.standard_normal(16000).astype(np.float32), 32000)
    lib = tmp_path / "lib"
    with pytest.raises(CacasError, match=r"short\.wav: is 0\.20 s long, mostly the silence that pads it to the "
                                         r"model's 1-s window; valid: a clip of at least 0\.5 s"):
        library.import_folder(src, root=lib)
    assert not lib.exists()
    (src / "cough" / "short.wav").unlink()
    assert "half.wav" in {p.name for p in library.import_folder(src, root=lib)}


def test_clip_seconds_reads_each_file_version_once_and_a_replaced_clip_afresh(tmp_path, monkeypatch):
    path = tmp_path / "a.wav"
    sf.write(path, np.zeros(16000, np.float32) + 0.1, 16000)
    opened = []
    real_info = sf.info
    monkeypatch.setattr(sf, "info", lambda p, *a, **k: opened.append(p) or real_info(p, *a, **k))
    assert library.clip_seconds(path) == pytest.approx(1.0)
    assert library.clip_seconds(path) == pytest.approx(1.0)
    assert len(opened) == 1  # the second call read no header
    replacement = tmp_path / "b.wav"
    sf.write(replacement, np.zeros(48000, np.float32) + 0.1, 16000)
    replacement.replace(path)  # as the library writes: a whole file renamed over the old one
    assert library.clip_seconds(path) == pytest.approx(3.0)
    assert len(opened) == 2
    assert library.clip_windows(path) > 0
    path.unlink()
    assert library.clip_seconds(path) == 0.0 and library.clip_windows(path) == 0
    (tmp_path / "bad.wav").write_bytes(b"not a wav")
    assert library.clip_seconds(tmp_path / "bad.wav") == 0.0


def test_import_says_every_bad_folder_file_type_and_clip_at_once(tmp_path):
    """A newcomer's folder (walkthrough): a folder named 'coughing', notes and an .mp3 beside the clips, a
    0.3-s clip. The folder name and each file type stopped the import one at a time (four tries); now one
    refusal lists them all, and nothing is copied."""
    src = _researcher_folder(tmp_path)
    (src / "cough").rename(src / "coughing")
    (src / "Watch TV" / "notes.txt").write_text("recorded on Tuesday")
    (src / "Watch TV" / "tv2.mp3").write_bytes(b"ID3")
    sf.write(src / "Watch TV" / "short.wav", np.full(int(0.3 * 16000), 0.2, np.float32), 16000)
    lib = tmp_path / "lib"
    with pytest.raises(CacasError) as err:
        library.import_folder(src, root=lib)
    lines = str(err.value).splitlines()
    # notes.txt and tv2.mp3 are not clips (walk3: "4 of the 5 clips")
    assert lines[0] == "2 of the 3 clips and 2 files that are not clips cannot be used; nothing was imported:"
    assert [line.split(": ")[0] for line in lines[1:]] == [
        f"- {src / 'Watch TV' / 'notes.txt'}", f"- {src / 'Watch TV' / 'short.wav'}",
        f"- {src / 'Watch TV' / 'tv2.mp3'}", f"- {src / 'coughing'}"]
    assert lines[3].endswith("unsupported file type '.mp3'; valid: .wav, .flac, .ogg")
    # the activity meant, as its folder is named (walkthrough: no hint, difflib's ratio 0.77)
    assert "folder name 'coughing' is not an activity; did you mean 'cough'? valid: cough, " in lines[4]
    assert not lib.exists()
    (src / "coughing").rename(src / "cough")
    (src / "Watch TV" / "tv2.mp3").unlink()
    with pytest.raises(CacasError, match=r"^1 of the 3 clips and 1 file that is not a clip cannot be used; "
                                         r"nothing was imported:\n"):
        library.import_folder(src, root=lib)
    (src / "Watch TV" / "short.wav").unlink()
    (src / "Watch TV" / "tv2.mp3").write_bytes(b"ID3")
    with pytest.raises(CacasError, match=r"^2 files that are not clips cannot be used; nothing was imported:\n"):
        library.import_folder(src, root=lib)
    assert not lib.exists()

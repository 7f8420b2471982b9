"""The scene library's scan and importer: the same rules as the sound library's
(cacas.media_library), with images."""

import numpy as np
import pytest
from PIL import Image

from cacas.errors import CacasError
from cacas.vision import library
from photos import photo


def _photos(tmp_path):
    src = tmp_path / "photos"
    (src / "Living Room").mkdir(parents=True)
    (src / "bedroom").mkdir()
    photo((40, 30), (10, 20, 30)).save(src / "Living Room" / "a.png")
    photo((40, 30), (90, 20, 30)).save(src / "bedroom" / "b.jpg")
    return src


def test_import_copies_checked_photos_by_scene(tmp_path):
    lib = tmp_path / "lib"
    told = []
    copied = library.import_folder(_photos(tmp_path), root=lib, progress=lambda f, m: told.append(f))
    assert sorted(p.relative_to(lib).as_posix() for p in copied) == ["bedroom/b.jpg", "living_room/a.png"]
    assert told[-1] == 1.0
    with pytest.raises(CacasError, match=r"a\.png: the same image is already in the library as living_room/a\.png"):
        library.import_folder(tmp_path / "photos", root=lib)
    photo((40, 30), (11, 20, 30)).save(tmp_path / "photos" / "Living Room" / "a.png")  # other photos
    photo((40, 30), (91, 20, 30)).save(tmp_path / "photos" / "bedroom" / "b.jpg")
    again = library.import_folder(tmp_path / "photos", root=lib)  # same names: kept apart, not overwritten
    assert sorted(p.name for p in again) == ["imported_1_a.png", "imported_1_b.jpg"]
    assert [p.scene for p in library.scan(lib)] == ["bedroom", "bedroom", "living room", "living room"]


@pytest.mark.parametrize("name, message", [
    ("notes.txt", r"notes\.txt: unsupported file type '\.txt'; valid: \.jpg, \.jpeg, \.png"),
    ("broken.jpg", r"broken\.jpg: not a readable image"),
])
def test_import_refuses_a_bad_file_and_copies_nothing(tmp_path, name, message):
    src = _photos(tmp_path)
    (src / "bedroom" / name).write_text("not an image")
    lib = tmp_path / "lib"
    with pytest.raises(CacasError, match=message):
        library.import_folder(src, root=lib)
    assert not lib.exists()


def test_import_of_a_missing_or_empty_folder_is_one_clear_message(tmp_path):
    with pytest.raises(CacasError, match=r"absent: no such folder; expected <folder>/<scene>/<image>\.jpg\|"):
        library.import_folder(tmp_path / "absent", root=tmp_path / "lib")
    (tmp_path / "photos" / "kitchen").mkdir(parents=True)
    with pytest.raises(CacasError, match=r"photos: no images found; expected <folder>/<scene>/<image>"):
        library.import_folder(tmp_path / "photos", root=tmp_path / "lib")
    (tmp_path / "photos" / "garage").mkdir()
    with pytest.raises(CacasError, match=r"folder name 'garage' is not a scene; valid: .*living_room"):
        library.import_folder(tmp_path / "photos", root=tmp_path / "lib")
    assert not (tmp_path / "lib").exists()


def test_scan_is_strict_about_folders_and_file_types(tmp_path):
    with pytest.raises(CacasError, match=r"absent: no such scene folder; expected <folder>/<scene>/<image>"):
        library.scan(tmp_path / "absent")
    assert library.scan(tmp_path) == []  # an empty library: the trainer says what to do
    src = _photos(tmp_path)
    (src / "bedroom" / "readme.md").write_text("x")
    with pytest.raises(CacasError, match=r"readme\.md: unsupported file type '\.md'"):
        library.scan(src)


def test_import_refuses_a_photo_too_small_to_show_a_room(tmp_path):
    """Review: a 1 x 1 pixel image was added to the scene library."""
    src = _photos(tmp_path)
    Image.new("RGB", (1, 1), (200, 20, 30)).save(src / "bedroom" / "tiny.png")
    lib = tmp_path / "lib"
    with pytest.raises(CacasError, match=r"tiny\.png: is 1 x 1 pixels; valid: a photo at least 16 pixels a side"):
        library.import_folder(src, root=lib)
    assert not lib.exists()


@pytest.mark.parametrize("make, message", [
    (lambda: Image.new("RGB", (64, 48), (12, 12, 12)),
     r"black\.jpg: is one flat colour \(RGB \(12, 12, 12\)\), a covered lens or a blank image; valid: a photo of the room"),
    (lambda: Image.new("RGBA", (64, 48), (0, 0, 0, 0)),
     r"clear\.png: is fully transparent, nothing of a room shows; valid: a photo of the room"),
    (lambda: Image.fromarray(np.dstack([np.tile(np.arange(64, dtype="uint8"), (48, 1))] * 3
                                       + [np.zeros((48, 64), "uint8")]), "RGBA"),
     r"hidden\.png: is fully transparent"),  # colours underneath, none of them shown
])
def test_import_refuses_an_image_with_nothing_of_a_room_in_it(tmp_path, make, message):
    """Walkthrough: a blank frame went into the scene library as a photo of the bedroom; a covered
    lens gives one."""
    src = _photos(tmp_path)
    name = message.split(":")[0].replace("\\", "")
    make().save(src / "bedroom" / name)
    lib = tmp_path / "lib"
    with pytest.raises(CacasError, match=message):
        library.import_folder(src, root=lib)
    assert not lib.exists()


def test_a_dim_room_is_still_a_photo(tmp_path):
    """The flat-colour bound is far below a real photo's spread: a dark evening room passes."""
    rng = np.random.default_rng(0)
    dim = Image.fromarray(rng.integers(5, 30, (48, 64, 3), dtype="uint8"), "RGB")  # spread ~7 levels
    dim.save(tmp_path / "dim.jpg")
    assert library.library_photo(tmp_path / "dim.jpg").size == (64, 48)


def test_a_16_bit_grey_photo_is_read_as_its_levels_and_refused_by_the_library(tmp_path):
    """Walkthrough: a 16-bit grey PNG reached the model 99.97 % white (Pillow clips every level above
    255), and in the library it stopped the Sounds and scenes page with a traceback (a page cannot
    draw it): it is read scaled to 8 bits, and the library refuses it with a message."""
    levels = np.tile(np.linspace(0, 65535, 64).astype(np.uint16), (48, 1))
    Image.fromarray(levels).save(tmp_path / "deep.png")  # mode I;16 (or I), 16 bits a pixel
    seen = np.asarray(library.load_image(tmp_path / "deep.png"))
    assert seen.shape == (48, 64, 3) and seen[0, 0, 0] == 0 and seen[0, -1, 0] == 255
    assert 120 <= seen[0, 32, 0] <= 135  # the middle level is mid-grey, not white
    with pytest.raises(CacasError, match=r"deep\.png: is a 16-bit grey image \(mode I;?1?6?.*\), which the pages "
                                         r"cannot show; valid: a photo of 8 bits a channel"):
        library.library_photo(tmp_path / "deep.png")


def test_an_image_too_large_to_read_safely_is_one_clear_message(tmp_path, monkeypatch):
    """Walkthrough: a 15000 x 15000 PNG gave Pillow's DecompressionBombError traceback (not an
    OSError), on the page and from `cacas scene recognize`."""
    photo((64, 48), (10, 20, 30)).save(tmp_path / "big.png")
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 1000)  # 64 x 48 = 3072 pixels: over twice the limit
    with pytest.raises(CacasError, match=r"big\.png: is too large to read safely \(more than 2,000 pixels\); "
                                         r"valid: a photo of at most 1,000 pixels"):
        library.load_image(tmp_path / "big.png")


def test_a_photo_with_an_exif_orientation_is_read_upright(tmp_path):
    """Helper's bug hunt: a phone's portrait photo, stored sideways with EXIF orientation 6 (turn 90
    degrees clockwise to show), reached the scene model and the pages on its side."""
    stored = Image.new("RGB", (60, 40), "white")
    stored.paste((200, 0, 0), (0, 0, 20, 40))  # the stored image's left third is red
    exif = Image.Exif()
    exif[0x0112] = 6
    path = tmp_path / "phone.jpg"
    stored.save(path, exif=exif, quality=95)
    upright = library.load_image(path)
    assert upright.size == (40, 60)
    r, g, b = upright.getpixel((20, 5))  # turned clockwise, the stored left side is on top
    assert r > 150 and g < 80 and b < 80


@pytest.mark.parametrize("replace", [False, True])
def test_a_folder_where_an_image_goes_is_refused_as_a_folder(tmp_path, replace):
    """CLI audit: as a clip's (test_audio_library): no --replace can replace a folder."""
    (tmp_path / "kitchen" / "synthetic_0_000.jpg").mkdir(parents=True)
    with pytest.raises(CacasError, match=r": a folder, where this run writes an image; valid: move or rename that "
                                         r"folder, or --out DIR for a library of its own; nothing was written$"):
        library.generate_scenes(1, size=32, root=tmp_path, replace=replace)
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")) == ["kitchen",
                                                                                      "kitchen/synthetic_0_000.jpg"]

"""Quotas on uploaded drawings (issue 30): 20 drawings of 1.9 MB went in within 1.5 s and
were kept a day. A user keeps their last DRAWINGS_PER_USER (one more forgets the oldest);
all users together DRAWING_BYTES_IN_ALL, past which an upload is refused saying when room
comes back; the upload form says both. On SQLite and on PostgreSQL."""

from __future__ import annotations

import html
import io
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from ezdxf.filemanagement import new as new_drawing
from flask import Flask
from flask.testing import FlaskClient
from sqlalchemy import func, select

from app.storage.library import (
    DRAWING_BYTES_IN_ALL,
    DRAWINGS_PER_USER,
    DrawingsFull,
    Library,
    NotFound,
    open_library,
)
from app.storage.models import DrawingRow
from app.web.extensions import get_library
from tests.web_support import accounts_app, csrf, dispose, local_app, log_in

MB = 1024 * 1024


def square(size: int) -> bytes:
    """A DXF of one square `size` inches a side (each size its own drawing)."""
    doc = new_drawing(units=1)
    msp = doc.modelspace()
    corners = [(0, 0), (size, 0), (size, size), (0, size)]
    for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
        msp.add_line(a, b)
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue().encode()


def upload(client: FlaskClient, data: bytes, name: str = "plate.dxf") -> tuple[int, str]:
    answer = client.post(
        "/drawings",
        data={"csrf_token": csrf(client), "file": (io.BytesIO(data), name)},
        content_type="multipart/form-data",
    )
    return answer.status_code, answer.headers.get("Location", "") or html.unescape(
        answer.get_data(as_text=True)
    )


def key_of(location: str) -> str:
    found = re.search(r"/drawings/([0-9a-f]{64})", location)
    assert found, location
    return found.group(1)


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = local_app(tmp_path)
    yield app
    dispose(app)


def test_a_user_keeps_their_last_drawings_and_the_form_says_so(app: Flask) -> None:
    client = app.test_client()
    page = html.unescape(client.get("/").get_data(as_text=True))
    assert f"You keep your last {DRAWINGS_PER_USER}: opening another forgets your oldest." in page
    assert f"The server keeps {DRAWING_BYTES_IN_ALL // MB} MB of drawings in all" in page
    keys = []
    for size in range(1, DRAWINGS_PER_USER + 2):
        status, location = upload(client, square(size))
        assert status == 302, location
        keys.append(key_of(location))
    forgotten = client.get(f"/drawings/{keys[0]}")
    assert forgotten.status_code == 404
    assert "upload it again" in forgotten.get_data(as_text=True)
    for key in keys[1:]:
        assert client.get(f"/drawings/{key}").status_code == 200


def test_one_user_s_uploads_never_forget_another_s(tmp_path: Path) -> None:
    app = accounts_app(tmp_path)
    try:
        ana, ada = app.test_client(), app.test_client()
        log_in(ana, "ana")
        log_in(ada, "ada")
        status, location = upload(ana, square(100))
        assert status == 302
        for size in range(1, DRAWINGS_PER_USER + 5):
            assert upload(ada, square(size))[0] == 302
        assert ana.get(f"/drawings/{key_of(location)}").status_code == 200
    finally:
        dispose(app)


def fill(library: Library) -> list[str]:
    """Drawings of 2 MB from several users, up to DRAWING_BYTES_IN_ALL exactly."""
    return [
        library.put_drawing(f"d{n}", bytes([n]) * (2 * MB), author=f"user{n // 10}")
        for n in range(DRAWING_BYTES_IN_ALL // (2 * MB))
    ]


def kept(library: Library) -> int:
    with library.session() as s:
        return int(s.scalar(select(func.count()).select_from(DrawingRow)) or 0)


def test_past_the_total_an_upload_is_refused_saying_when_room_comes_back(app: Flask) -> None:
    with app.app_context():
        fill(get_library())
    client = app.test_client()
    status, page = upload(client, square(3), "last.dxf")
    assert status == 422
    assert (
        f"Not opened: last.dxf: the server keeps at most {DRAWING_BYTES_IN_ALL // MB} MB of "
        "uploaded drawings and has 64.0 MB; each is kept a day, so room comes back at "
    ) in page
    with app.app_context():
        assert kept(get_library()) == DRAWING_BYTES_IN_ALL // (2 * MB)


def test_the_limits_hold_on_either_database(database_url: str) -> None:
    library = open_library(database_url, seed_demo=False)
    try:
        keys = fill(library)
        with pytest.raises(DrawingsFull, match="room comes back at"):
            library.put_drawing("one more", b"\xfe" * 1000, author="newcomer")
        assert kept(library) == len(keys)
        # The same drawing again is no new byte.
        assert library.put_drawing("d0 again", bytes([0]) * (2 * MB), author="user0") == keys[0]
        # user0 has ten: one more forgets user0's oldest (d1, since d0 came again), which
        # makes room for it.
        library.put_drawing("small", b"\xfd" * 1000, author="user0")
        assert kept(library) == len(keys)
        with pytest.raises(NotFound):
            library.drawing(keys[1])
        assert library.drawing(keys[0])[0] == "d0 again"
    finally:
        library.engine.dispose()

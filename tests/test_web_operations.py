"""The editor offers issue 33's operations in its menus and enters them from the form, text
and all (ENGRAVE's TEXT is a field like no other: not a number)."""

from __future__ import annotations

from flask.testing import FlaskClient

from tests.test_web import app, client, token

__all__ = ["app", "client"]


def new_program(client: FlaskClient, csrf: str) -> int:
    response = client.post("/programs", data={"csrf_token": csrf, "name": "OPS", "units": "inch"})
    program_id = int(response.headers["Location"].split("/")[2])
    response = client.post(
        f"/programs/{program_id}/db0",
        data={
            "csrf_token": csrf,
            "version": "1",
            "x_offset": "0",
            "y_offset": "0",
            "current_tool": "1",
            "milling": "climb",
            "z_retract": "0.1",
            "dia_1": "0.063",
            "rpm_1": "4000",
            "tcal_1": "0",
        },
    )
    assert response.status_code == 302
    return program_id


def test_the_menus_offer_the_operations(client: FlaskClient) -> None:
    csrf = token(client)
    program_id = new_program(client, csrf)
    for group, titles in (
        ("BORE", ["HELIX"]),
        ("TAP", ["THREAD MILL INT", "THREAD MILL EXT"]),
        ("POCKET", ["FACE", "FACE ONE WAY", "ENGRAVE LINE", "ENGRAVE ARC"]),
    ):
        page = client.get(f"/programs/{program_id}/entry?at=1&group={group}").get_data(as_text=True)
        for title in titles:
            assert f'<span class="what">{title}</span>' in page, (group, title)


def test_engrave_is_entered_with_its_text(client: FlaskClient) -> None:
    csrf = token(client)
    program_id = new_program(client, csrf)
    response = client.post(
        f"/programs/{program_id}/blocks",
        data={
            "csrf_token": csrf,
            "version": "2",
            "kind": "ENGRAVE_LINE",
            "at": "1",
            "units": "inch",
            "text": "PN-42",
            "x": "0.5",
            "y": "0.5",
            "angle": "30",
            "height": "0.25",
            "z_up": "0.02",
            "z_dn": "-0.01",
            "feed_z": "2",
            "feed_xy": "10",
            "tool": "1",
        },
    )
    assert response.status_code == 302
    page = client.get(f"/programs/{program_id}").get_data(as_text=True)
    assert "ENGRAVE LINE" in page and "PN-42" in page

"""The API token (issue 18): asked on every route but /health, the page's files and the
API docs; compared in constant time; required to listen beyond the loopback."""

from __future__ import annotations

import os
import subprocess

import pytest
from fastapi.testclient import TestClient
from service_helpers import assert_error, free_port, serve_command

from brdffit_service import Settings, create_app
from brdffit_service.security import check_listen, is_loopback
from brdffit_service.settings import SettingsError

TOKEN = "s3cret-token-for-tests"


@pytest.fixture(scope="module")
def guarded(tmp_path_factory):
    settings = Settings(store_path=tmp_path_factory.mktemp("token") / "jobs.sqlite3",
                        workers=1, api_token=TOKEN)  # fmt: skip
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


def test_every_route_but_the_public_ones_needs_the_token(guarded):
    for path in ("/health", "/", "/static/app.js", "/openapi.json", "/docs"):
        assert guarded.get(path).status_code == 200, path
    for method, path in (("GET", "/jobs"), ("GET", "/models"), ("GET", "/jobs/x"),
                         ("DELETE", "/jobs/x"), ("POST", "/jobs/x/cancel"), ("POST", "/fit"),
                         ("GET", "/examples"), ("POST", "/health")):  # fmt: skip
        answer = guarded.request(method, path)
        body = assert_error(answer, 401, "authorization", "no token")
        assert answer.headers["www-authenticate"] == "Bearer" and body["kind"] == "Unauthorized"
    wrong = guarded.get("/jobs", headers={"Authorization": f"Bearer {TOKEN}x"})
    assert_error(wrong, 401, "authorization", "wrong token")
    basic = guarded.get("/jobs", headers={"Authorization": f"Basic {TOKEN}"})
    assert_error(basic, 401, "authorization")
    right = guarded.get("/jobs", headers={"Authorization": f"Bearer {TOKEN}"})
    assert right.status_code == 200 and right.json() == []


def test_without_a_token_only_clients_on_the_loopback_are_served(tmp_path):
    settings = Settings(store_path=tmp_path / "jobs.sqlite3", workers=1)
    app = create_app(settings)
    with TestClient(app, client=("127.0.0.1", 5000)) as local:
        assert local.get("/jobs").status_code == 200
    with TestClient(app, client=("203.0.113.7", 5000)) as remote:
        assert remote.get("/health").status_code == 200
        assert_error(remote.get("/jobs"), 401, "authorization", "BRDFFIT_API_TOKEN")
    open_app = create_app(settings.model_copy(update={"allow_no_token": True}))
    with TestClient(open_app, client=("203.0.113.7", 5000)) as remote:
        assert remote.get("/jobs").status_code == 200


def test_listening_beyond_the_loopback_needs_a_token_or_insecure(tmp_path):
    settings = Settings(store_path=tmp_path / "jobs.sqlite3")
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.4")
    assert check_listen(settings, "127.0.0.1") is settings
    with pytest.raises(SettingsError, match=r"BRDFFIT_API_TOKEN.*--insecure"):
        check_listen(settings, "0.0.0.0")
    assert check_listen(settings, "0.0.0.0", insecure=True).allow_no_token
    with_token = Settings(store_path=tmp_path / "jobs.sqlite3", api_token=TOKEN)
    assert check_listen(with_token, "0.0.0.0") is with_token
    from_env = Settings.from_env({"BRDFFIT_API_TOKEN": TOKEN, "BRDFFIT_ALLOW_NO_TOKEN": "1"})
    assert from_env.api_token.get_secret_value() == TOKEN and from_env.allow_no_token
    assert TOKEN not in repr(from_env)
    with pytest.raises(SettingsError, match=r"api_token=\(hidden\)"):
        Settings.from_env({"BRDFFIT_API_TOKEN": ""})


def test_brdffit_serve_refuses_a_public_address_without_a_token(tmp_path):
    """Refused before anything binds: nothing listens beyond the loopback here."""
    command = serve_command(tmp_path / "jobs.sqlite3", free_port(), host="0.0.0.0")
    env = {k: v for k, v in os.environ.items() if not k.startswith("BRDFFIT_")}
    done = subprocess.run(command, capture_output=True, text=True, timeout=60, env=env)
    assert done.returncode == 2, done.stderr
    assert "--host 0.0.0.0 listens beyond this machine" in done.stderr
    assert "BRDFFIT_API_TOKEN" in done.stderr and "--insecure" in done.stderr


def test_the_openapi_document_asks_for_the_token_when_there_is_one(guarded, client):
    spec = guarded.get("/openapi.json").json()
    assert spec["components"]["securitySchemes"]["token"]["scheme"] == "bearer"
    assert spec["security"] == [{"token": []}]
    assert spec["paths"]["/health"]["get"]["security"] == []
    assert "securitySchemes" not in client.get("/openapi.json").json()["components"]

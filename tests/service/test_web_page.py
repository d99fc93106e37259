"""The web page without a browser: its HTML's accessibility points, its files as
package data, and the routes it needs (comparisons, plots, examples) through
FastAPI's TestClient. The page in a real browser: ``test_web_browser.py``."""

from __future__ import annotations

import re
import sys
import time
from html.parser import HTMLParser

import pytest
from fastapi.testclient import TestClient
from service_helpers import ROOT, wait_for
from service_helpers import WARD_CSV as WARD

import brdffit
import brdffit.models
from brdffit_service import Settings, create_app
from brdffit_service.comparisons import ranks
from brdffit_service.routes.comparisons import MAX_MODELS
from brdffit_service.routes.web import WEB, page_file

FILES = ("index.html", "app.css", "app.js")
TOO_MANY = ",".join(sorted(brdffit.models.REGISTRY)[: MAX_MODELS + 1])
WALKERS = "options.posterior_options.walkers"


class Tags(HTMLParser):
    """Every start tag with its attributes, and the text inside each <label> and <button>."""

    def __init__(self):
        super().__init__()
        self.tags: list[tuple[str, dict]] = []
        self.text: dict[int, str] = {}
        self._open: list[int] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if tag in ("label", "button"):
            self._open.append(len(self.tags) - 1)

    def handle_endtag(self, tag):
        if tag in ("label", "button") and self._open:
            self._open.pop()

    def handle_data(self, data):
        for i in self._open:
            self.text[i] = self.text.get(i, "") + data


@pytest.fixture(scope="module")
def page() -> Tags:
    parser = Tags()
    parser.feed(page_file("index.html").decode())
    return parser


def test_every_control_has_a_label(page):
    labelled = {a["for"] for t, a in page.tags if t == "label" and "for" in a}
    controls = [a for t, a in page.tags if t in ("input", "select", "textarea")]
    assert len(controls) >= 12
    for attrs in controls:
        assert attrs.get("id") in labelled, f"control {attrs} has no <label for=...>"


def test_ids_are_unique_and_references_resolve(page):
    ids = [a["id"] for _, a in page.tags if "id" in a]
    assert len(ids) == len(set(ids)), sorted(i for i in ids if ids.count(i) > 1)
    for _, attrs in page.tags:
        for ref in [*attrs.get("aria-describedby", "").split(), attrs.get("for")]:
            assert ref is None or ref in ids, f"{attrs} refers to a missing id {ref!r}"


def test_language_viewport_buttons_and_tables(page):
    assert ("html", {"lang": "en"}) in page.tags
    metas = [a for t, a in page.tags if t == "meta"]
    assert any(a.get("name") == "viewport" and "width=device-width" in a["content"] for a in metas)
    buttons = [i for i, (t, _) in enumerate(page.tags) if t == "button"]
    assert buttons and all(page.text.get(i, "").strip() for i in buttons)
    headers = [a for t, a in page.tags if t == "th"]
    assert headers and all(a.get("scope") == "col" for a in headers)


def test_nothing_is_fetched_from_elsewhere():
    for name in FILES:
        text = page_file(name).decode()
        assert not re.search(r"(https?:)?//[a-z0-9.-]+\.[a-z]{2,}", text), name
        assert "@import" not in text, name
    script = page_file("app.js").decode()
    calls = re.findall(r"(?:fetch|getJSON)\(([^,)]+)", script)
    assert len(calls) >= 6
    assert all(re.match(r"""["`]/""", c) or c in ("url", "src") for c in calls), calls


def test_the_page_files_ship_as_package_data():
    if sys.version_info < (3, 11):
        pytest.skip("tomllib needs Python 3.11")
    from fnmatch import fnmatch

    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    globs = config["tool"]["setuptools"]["package-data"]["brdffit_service"]
    shipped = sorted(p.name for p in (ROOT / "service" / "web").iterdir() if p.is_file())
    assert shipped == sorted(FILES)
    for name in shipped:
        assert any(fnmatch(f"web/{name}", g) for g in globs), name
    # The routes find them through importlib.resources, wherever the package lives.
    assert all((WEB / name).is_file() for name in FILES)


def test_ranks():
    assert ranks([3.0, None, 1.0, 2.0]) == [3, None, 1, 2]
    assert ranks([None]) == [None]


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    store = tmp_path_factory.mktemp("web") / "jobs.sqlite3"
    settings = Settings(store_path=store, workers=1, job_timeout=30.0)
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


def test_page_static_files_and_examples(client):
    page = client.get("/")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert page.content == page_file("index.html")
    assert client.get("/static/app.js").headers["content-type"].startswith("text/javascript")
    assert client.get("/static/secret.py").status_code == 404
    examples = {e["name"]: e for e in client.get("/examples").json()}
    assert examples["ward.csv"]["model"] == "ward" and examples["ward.csv"]["n"] == 568
    assert client.get("/examples/ward.csv").content == WARD.read_bytes()
    for name in ("../pyproject.toml", "truth.json", "generate.py"):
        assert client.get(f"/examples/{name}").status_code == 404


def _post(client, models: str, options: str = "{}", name="ward.csv", content=None, **form):
    content = WARD.read_bytes() if content is None else content
    data = {"models": models, "options": options, **form}
    return client.post("/comparisons/file", files={"file": (name, content)}, data=data)


@pytest.mark.parametrize(
    ("models", "options", "content", "form", "field"),
    [
        ("wardd", "{}", None, {}, "models"),
        (" , ", "{}", None, {}, "models"),
        (TOO_MANY, "{}", None, {}, "models"),
        ("ward", '{"loss": "nope"}', None, {}, "options.loss"),
        ("ward", '{"posterior_options": {"walkers": 0}}', None, {}, WALKERS),
        ("ward", "{}", b"no,header\n1,2\n", {}, "file.header"),
        ("ward", "{}", None, {"test_fraction": "0.95"}, "test_fraction"),
    ],
)
def test_comparison_errors_name_the_field(client, models, options, content, form, field):
    answer = _post(client, models, options, content=content, **form)
    assert answer.status_code == 422, answer.text
    assert answer.json()["field"] == field, answer.json()


def test_a_comparison_matches_brdffit_compare(client):
    answer = _post(client, "ward,lambert", '{"seed": 4}', test_fraction="0.25")
    assert answer.status_code == 202, answer.text
    comparison = answer.json()
    assert client.get(answer.headers["location"]).json()["id"] == comparison["id"]
    deadline = time.monotonic() + 60
    while not comparison["done"]:
        assert time.monotonic() < deadline, comparison
        time.sleep(0.2)
        comparison = client.get(f"/comparisons/{comparison['id']}").json()
    expected = brdffit.compare(brdffit.read(WARD), ["ward", "lambert"], test_fraction=0.25, seed=4)
    assert (comparison["n_train"], comparison["n_test"]) == (expected.n_train, expected.n_test)
    by_model = {e.model: e for e in expected.entries}
    for entry in comparison["entries"]:
        want = by_model[entry["model"]]
        assert entry["status"] == "done"
        assert entry["heldout_rmse"] == pytest.approx(want.heldout_rmse, rel=1e-6)
        assert entry["bic"] == pytest.approx(want.bic, rel=1e-6)
        assert (entry["rank_heldout"], entry["rank_bic"]) == (want.rank_heldout, want.rank_bic)
    listed = client.get("/comparisons").json()
    assert listed[0]["id"] == comparison["id"] and listed[0]["models"] == ["ward", "lambert"]

    job = comparison["entries"][0]["job"]
    plot = client.get(f"/jobs/{job}/plot.png")
    assert plot.status_code == 200 and plot.content.startswith(b"\x89PNG\r\n\x1a\n")
    corner = client.get(f"/jobs/{job}/corner.png")
    assert corner.status_code == 404 and "did not sample" in corner.json()["message"]
    assert client.delete(f"/jobs/{job}").status_code == 204
    assert client.get(f"/jobs/{job}/plot.png").json()["field"] == "id"
    assert client.get(f"/comparisons/{comparison['id']}").json()["entries"][0]["status"] == (
        "deleted"
    )


def test_a_plain_job_has_a_fit_plot_but_no_corner_plot(client):
    options = '{"uncertainty": true, "posterior_options": {"steps": 100}}'
    answer = client.post("/jobs/file", files={"file": ("ward.csv", WARD.read_bytes())},
                         data={"model": "ward", "options": options})  # fmt: skip
    assert answer.status_code == 202, answer.text
    job = wait_for(client, answer.json()["id"])
    assert job["status"] == "done" and job["result"]["posterior"]
    plot = client.get(f"/jobs/{job['id']}/plot.png")
    assert plot.status_code == 200 and plot.content.startswith(b"\x89PNG\r\n\x1a\n")
    assert client.get(f"/jobs/{job['id']}/plot.png").content == plot.content  # kept
    corner = client.get(f"/jobs/{job['id']}/corner.png")
    assert corner.status_code == 404 and "POST /comparisons/file" in corner.json()["message"]


def test_unknown_comparison_and_plot_names(client):
    assert client.get("/comparisons/nope").json()["field"] == "id"
    assert client.get("/jobs/nope/plot.png").status_code == 404
    assert client.get("/jobs/nope/other.png").status_code == 404

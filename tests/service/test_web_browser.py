"""The web page in a real browser: headless Chromium (Debian's ``chromium`` and
``chromium-driver``) driven by Selenium, against the service on a free loopback port.

Nothing is downloaded at test time: the driver and the browser are the system's
(``.ci/run`` installs them when missing); selenium-manager is never asked.
Screenshots of each state go to ``tests/artifacts/`` (not committed); with
``BRDFFIT_WEB_SCREENSHOT=docs`` the results at 1280x800 also go to
``docs/web_results.png``, the README's picture.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import httpx
import pytest
from service_helpers import ROOT, Server
from service_helpers import WARD_CSV as WARD

TRUTH = ROOT / "data_synthetic" / "truth.json"
ARTIFACTS = ROOT / "tests" / "artifacts"
CHROMIUM, CHROMEDRIVER = Path("/usr/bin/chromium"), Path("/usr/bin/chromedriver")
MODELS = ["ward", "ggx", "blinn"]

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed "
                                "(pip install -e '.[test]')")  # fmt: skip
pytestmark = pytest.mark.skipif(
    not (CHROMIUM.exists() and CHROMEDRIVER.exists()),
    reason=f"{CHROMIUM} or {CHROMEDRIVER} is absent: apt-get install chromium chromium-driver "
    "(.ci/run does)",
)
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.common.keys import Keys  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """The URL of ``brdffit serve`` on a free loopback port, with a fresh store."""
    folder = tmp_path_factory.mktemp("web")
    running = Server(folder / "jobs.sqlite3", folder / "server.log", workers=2)
    yield running.url
    running.reap()


@pytest.fixture(scope="module")
def browser():
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="brdffit-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage",
                 f"--user-data-dir={profile}", "--window-size=1280,800"):  # fmt: skip
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(executable_path=str(CHROMEDRIVER)), options=options)
    driver.set_window_size(1280, 800)
    ARTIFACTS.mkdir(exist_ok=True)
    yield driver
    driver.quit()
    shutil.rmtree(profile, ignore_errors=True)


def shot(driver, name: str) -> Path:
    path = ARTIFACTS / f"web_{name}.png"
    driver.save_screenshot(str(path))
    return path


def open_page(driver, url: str) -> None:
    driver.get(url)
    WebDriverWait(driver, 20).until(
        lambda d: d.execute_script("return document.body.dataset.ready === 'true'")
    )


def fill_form(driver, path: Path | str, models, *, steps: int, seconds: int) -> None:
    """``path``: a file to upload with the file picker, or the name of an example."""
    if isinstance(path, Path):
        driver.find_element(By.ID, "file").send_keys(str(path))
    else:
        Select(driver.find_element(By.ID, "example")).select_by_value(path)
    driver.find_element(By.ID, "clear-models").click()
    for name in models:
        driver.find_element(By.ID, f"m-{name}").click()
    if not driver.find_element(By.ID, "uncertainty").is_selected():
        driver.find_element(By.ID, "uncertainty").click()
    driver.find_element(By.TAG_NAME, "summary").click()
    for field, value in (("steps", steps), ("timeout", seconds)):
        box = driver.find_element(By.ID, field)
        box.clear()
        box.send_keys(str(value))


def wait_results(driver, n: int, seconds: float = 60):
    WebDriverWait(driver, seconds).until(
        lambda d: (
            d.find_element(By.ID, "results").is_displayed()
            and len(d.find_elements(By.CSS_SELECTOR, "#model-results article")) == n
        )
    )


def cell(row, selector: str) -> str:
    return row.find_element(By.CSS_SELECTOR, selector).text


def test_compare_three_models_with_uncertainty(server, browser):
    open_page(browser, server + "/")
    # Every control, the model checkboxes the script made included, has a label.
    unlabelled = browser.execute_script(
        "return [...document.querySelectorAll('input, select')]"
        ".filter(c => !c.labels.length).map(c => c.id || c.outerHTML)"
    )
    assert unlabelled == []
    assert len(browser.find_elements(By.CSS_SELECTOR, "#model-list input")) >= 20
    fill_form(browser, WARD, MODELS, steps=300, seconds=10)
    shot(browser, "1_form")
    browser.find_element(By.ID, "submit").click()
    WebDriverWait(browser, 20).until(lambda d: "comparison=" in d.current_url)
    WebDriverWait(browser, 20).until(
        lambda d: len(d.find_elements(By.CSS_SELECTOR, "#progress-table tbody tr")) == 3
    )
    shot(browser, "2_progress")
    wait_results(browser, 3)

    # The ranking: every model done, ward (the model that made the data) first both ways.
    rows = browser.find_elements(By.CSS_SELECTOR, "#ranking tbody tr")
    assert sorted(r.get_attribute("data-model") for r in rows) == sorted(MODELS)
    assert [cell(r, "td:last-child") for r in rows] == ["done"] * 3
    assert rows[0].get_attribute("data-model") == "ward"
    assert (cell(rows[0], ".rank-heldout"), cell(rows[0], ".rank-bic")) == ("1", "1")
    assert sorted(cell(r, ".rank-heldout") for r in rows) == ["1", "2", "3"]

    # Ward's parameters against the truth that made the file: 1 % noise, so each
    # fitted value within 3 % of the truth, and the truth within 4 posterior sigmas.
    truth = json.loads(TRUTH.read_text())["files"]["ward.csv"]
    expected = {}
    for name, value in truth["params"].items():
        if isinstance(value, list):
            expected.update({f"{name}[{c}]": v for c, v in zip(truth["channels"], value)})
        else:
            expected[name] = value
    article = browser.find_element(By.CSS_SELECTOR, "#model-results article[data-model=ward]")
    for key, value in expected.items():
        row = article.find_element(By.CSS_SELECTOR, f'tr[data-param="{key}"]')
        fitted = float(row.find_element(By.CSS_SELECTOR, ".value").get_attribute("data-value"))
        interval = row.find_element(By.CSS_SELECTOR, ".interval")
        p16, p84 = (float(interval.get_attribute(a)) for a in ("data-p16", "data-p84"))
        assert abs(fitted - value) <= 0.03 * value, (key, fitted, value)
        assert abs(fitted - value) <= 4 * (p84 - p16) / 2, (key, fitted, value, p16, p84)

    # Every picture loaded: a fit plot per model and a corner plot per posterior.
    for img in browser.find_elements(By.CSS_SELECTOR, "#model-results img"):
        browser.execute_script("arguments[0].scrollIntoView()", img)
    WebDriverWait(browser, 30).until(lambda d: d.execute_script(
        "return [...document.images].every(i => i.complete)"))  # fmt: skip
    widths = browser.execute_script("return [...document.images].map(i => i.naturalWidth)")
    assert len(widths) == 6 and all(w > 0 for w in widths), widths
    notes = browser.find_element(By.ID, "notes").text
    assert notes.startswith("Notes about the data"), notes
    check_export_download(browser, article, server)

    browser.execute_script("document.getElementById('results').scrollIntoView()")
    shot(browser, "3_results")
    if os.environ.get("BRDFFIT_WEB_SCREENSHOT") == "docs":
        # The README's picture: a taller window, so that the ranking, ward's
        # parameters and its plots show together.
        browser.set_window_size(1280, 1500)
        browser.execute_script("document.getElementById('results').scrollIntoView()")
        picture = ARTIFACTS / "web_results_tall.png"
        browser.save_screenshot(str(picture))
        from PIL import Image  # matplotlib's dependency; a palette keeps the file small

        with Image.open(picture) as image:
            small = image.convert("RGB").quantize(colors=256)
            small.save(ROOT / "docs" / "web_results.png", optimize=True)

    # The recent jobs list them, done.
    recent = browser.find_elements(By.CSS_SELECTOR, "#recent-table tbody tr")
    assert [r.find_elements(By.TAG_NAME, "td")[2].text for r in recent[:3]] == ["done"] * 3
    assert sorted(r.find_elements(By.TAG_NAME, "td")[1].text for r in recent[:3]) == sorted(MODELS)

    # Readable on a phone: nothing wider than the window, the ranking still there.
    browser.set_window_size(390, 844)
    try:
        overflow = browser.execute_script(
            "return document.documentElement.scrollWidth - window.innerWidth"
        )
        assert overflow <= 0, f"the page is {overflow} px wider than a phone's window"
        assert browser.find_element(By.ID, "ranking").is_displayed()
        shot(browser, "4_phone")
    finally:
        browser.set_window_size(1280, 800)


def check_export_download(browser, article, server: str) -> None:
    """Ward's renderer exports: a labelled button per target; the glTF one, pressed
    from the keyboard, saves a glTF asset whose material is the export's; the Mitsuba
    XML one an XML file named by the library's ending."""
    targets = httpx.get(server + "/export/targets").json()
    buttons = article.find_elements(By.CSS_SELECTOR, ".exports button")
    assert [b.get_attribute("data-target") for b in buttons] == list(targets)
    assert all("ward" in b.get_attribute("aria-label") for b in buttons)
    folder = Path(tempfile.mkdtemp(prefix="brdffit-downloads-"))
    browser.execute_cdp_cmd("Browser.setDownloadBehavior",
                            {"behavior": "allow", "downloadPath": str(folder)})  # fmt: skip
    try:
        gltf = article.find_element(By.CSS_SELECTOR, '.exports button[data-target="gltf"]')
        browser.execute_script("arguments[0].focus()", gltf)
        gltf.send_keys(Keys.ENTER)
        saved = folder / "ward.gltf"
        WebDriverWait(browser, 20).until(lambda d: saved.exists() and saved.stat().st_size > 0)
        asset = json.loads(saved.read_text())
        assert asset["asset"]["version"] == "2.0"
        (material,) = asset["materials"]
        pbr = material["pbrMetallicRoughness"]
        assert 0 < pbr["roughnessFactor"] <= 1 and len(pbr["baseColorFactor"]) == 4
        status = article.find_element(By.CSS_SELECTOR, ".export-status").text
        assert status.startswith("Saved ward.gltf") and "RMS" in status, status
        # The ending is the library's (the answer's), the target named beside it.
        article.find_element(By.CSS_SELECTOR, '.exports button[data-target="mitsuba-xml"]').click()
        xml = folder / "ward.mitsuba-xml.xml"
        WebDriverWait(browser, 20).until(lambda d: xml.exists() and xml.stat().st_size > 0)
        assert xml.read_text().lstrip().startswith("<bsdf")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def test_bad_file_shows_the_error_next_to_the_file(server, browser, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("this is not,a measurement\n1,2\n")
    open_page(browser, server + "/")
    fill_form(browser, bad, ["ward"], steps=100, seconds=5)
    browser.find_element(By.ID, "submit").click()
    error = WebDriverWait(browser, 20).until(
        lambda d: (
            d.find_element(By.ID, "file-error").is_displayed()
            and d.find_element(By.ID, "file-error")
        )
    )
    assert "bad.csv" in error.text and error.text.startswith("file"), error.text
    assert browser.find_element(By.ID, "file").get_attribute("aria-invalid") == "true"
    assert not browser.find_element(By.ID, "models-error").is_displayed()
    assert "comparison=" not in browser.current_url
    shot(browser, "5_bad_file")

    # A model the service does not know: the message is beside the models' field.
    open_page(browser, server + "/")
    fill_form(browser, WARD, [], steps=100, seconds=5)
    # From the keyboard: Enter in the text field submits the form.
    browser.find_element(By.ID, "models-extra").send_keys("wardd" + Keys.ENTER)
    error = WebDriverWait(browser, 20).until(
        lambda d: (
            d.find_element(By.ID, "models-error").is_displayed()
            and d.find_element(By.ID, "models-error")
        )
    )
    assert "wardd" in error.text and "ward" in error.text.replace("wardd", ""), error.text
    assert not browser.find_element(By.ID, "file-error").is_displayed()
    shot(browser, "6_bad_model")


def test_dropping_a_file_chooses_it(server, browser):
    open_page(browser, server + "/")
    browser.execute_script(
        """const drop = new DataTransfer();
        drop.items.add(new File(["theta_i,phi_i,theta_o,phi_o,value"], "dropped.csv"));
        const zone = document.getElementById("drop");
        zone.dispatchEvent(new DragEvent("dragover", {dataTransfer: drop, bubbles: true}));
        zone.dispatchEvent(new DragEvent("drop", {dataTransfer: drop, bubbles: true}));"""
    )
    assert browser.find_element(By.ID, "chosen").text == "Chosen: dropped.csv (33 bytes)"


def test_a_reload_keeps_following_the_job(server, browser):
    open_page(browser, server + "/")
    # The bundled example this time, and a posterior of many steps stopped by its
    # time budget: a job of about 6 s.
    fill_form(browser, "ward.csv", ["ggx"], steps=1_000_000, seconds=5)
    browser.find_element(By.ID, "submit").click()
    WebDriverWait(browser, 20).until(lambda d: "comparison=" in d.current_url)
    url = browser.current_url
    status = "#progress-table tbody tr td"
    WebDriverWait(browser, 20).until(
        lambda d: (
            d.find_elements(By.CSS_SELECTOR, status)
            and d.find_element(By.CSS_SELECTOR, status).text == "running"
        )
    )
    browser.refresh()
    WebDriverWait(browser, 20).until(
        lambda d: d.execute_script("return document.body.dataset.ready === 'true'")
    )
    assert browser.current_url == url
    WebDriverWait(browser, 20).until(
        lambda d: d.find_elements(By.CSS_SELECTOR, "#progress-table tbody tr")
    )
    rows = browser.find_elements(By.CSS_SELECTOR, "#progress-table tbody tr")
    assert [r.find_element(By.TAG_NAME, "th").text for r in rows] == ["ggx"]
    assert rows[0].find_element(By.TAG_NAME, "td").text == "running"
    shot(browser, "7_reloaded")
    # Progress keeps coming without a reload: the posterior's steps are shown.
    WebDriverWait(browser, 20).until(
        lambda d: "posterior, step" in d.find_element(By.ID, "progress-table").text
    )
    wait_results(browser, 1, seconds=40)
    assert browser.find_element(By.CSS_SELECTOR, "#ranking tbody tr td:last-child").text == "done"


def test_a_server_with_a_token_asks_for_it_and_sends_it(browser, tmp_path):
    """BRDFFIT_API_TOKEN (issue 18): the page asks for the token, keeps it for the tab
    and sends it on its API calls, pictures and downloads included (fetched, since
    <img> and <a download> cannot)."""
    token = "page-token-1234"
    guarded = Server(tmp_path / "jobs.sqlite3", tmp_path / "server.log", workers=1,
                     env={"BRDFFIT_API_TOKEN": token})  # fmt: skip
    try:
        open_page(browser, guarded.url + "/")
        box = browser.find_element(By.ID, "token-box")
        WebDriverWait(browser, 10).until(lambda d: box.is_displayed())
        assert browser.find_elements(By.CSS_SELECTOR, "#model-list input") == []
        browser.find_element(By.ID, "token").send_keys(token)
        browser.find_element(By.CSS_SELECTOR, "#token-form button").click()
        WebDriverWait(browser, 20).until(
            lambda d: len(d.find_elements(By.CSS_SELECTOR, "#model-list input")) >= 20
        )
        assert not browser.find_element(By.ID, "token-box").is_displayed()
        fill_form(browser, WARD, ["ward"], steps=100, seconds=5)
        browser.find_element(By.ID, "submit").click()
        wait_results(browser, 1)
        WebDriverWait(browser, 30).until(lambda d: d.execute_script(
            "const i = [...document.querySelectorAll('#model-results img')];"
            "return i.length > 0 && i.every(x => x.src.startsWith('blob:') && x.naturalWidth > 0)"
        ))  # fmt: skip
        # The download links send the token too: the result's JSON is the job's.
        folder = tmp_path / "downloads"
        folder.mkdir()
        browser.execute_cdp_cmd("Browser.setDownloadBehavior",
                                {"behavior": "allow", "downloadPath": str(folder)})  # fmt: skip
        link = browser.find_element(By.CSS_SELECTOR, '#model-results a[href^="/jobs/"]')
        saved = folder / link.get_attribute("download")
        link.click()
        WebDriverWait(browser, 20).until(lambda d: saved.exists() and saved.stat().st_size > 0)
        job = json.loads(saved.read_text())
        assert job["status"] == "done" and job["model"] == "ward", job
    finally:
        browser.execute_script("sessionStorage.clear()")
        guarded.reap()


def test_the_api_docs_render_from_the_package(server, browser):
    """Swagger UI comes from the package (it came from a CDN: blank offline)."""
    browser.get(server + "/docs")
    title = WebDriverWait(browser, 30).until(
        lambda d: d.find_elements(By.CSS_SELECTOR, ".swagger-ui .info .title")
    )
    assert title[0].text.startswith("brdffit")
    assert len(browser.find_elements(By.CSS_SELECTOR, ".opblock")) >= 15
    loaded = browser.execute_script(
        "return performance.getEntriesByType('resource').map(e => e.name)"
    )
    assert loaded and all(url.startswith(server) for url in loaded), loaded

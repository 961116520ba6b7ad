"""Shared fixtures for the ingest tests: paths to ../shared/data and the real ERCOT workbook, parsed once."""

from __future__ import annotations

from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[3] / ".." / "shared" / "data"
WORKBOOK = SHARED / "ercot" / "IntGenbyFuel2017.xlsx"
EPW = SHARED / "weather" / "USA_TX_Austin-Camp.Mabry.722544_TMY3.epw"
RESSTOCK_WEATHER = SHARED / "weather" / "G3600010.csv"


def need(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"../shared/data not present: {path}")
    return path


@pytest.fixture(scope="session")
def workbook_hourly():
    """Hourly MWh per fuel parsed from the real 2017 workbook by the code under test."""
    from pipeline.ingest.fuel_mix import read_fuel_mix_workbook

    return read_fuel_mix_workbook(need(WORKBOOK))[0]


@pytest.fixture(scope="session")
def workbook_rows():
    """The workbook's own rows, read directly with openpyxl: {(date, fuel): (Total, [cells in column order])}."""
    import openpyxl

    book = openpyxl.load_workbook(need(WORKBOOK), read_only=True, data_only=True)
    rows = {}
    for name in ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"):
        sheet = book[name]
        sheet.reset_dimensions()
        for row in list(sheet.iter_rows(values_only=True))[1:]:
            if row and row[0] is not None:
                rows[(row[0].date(), row[1])] = (row[3], list(row[4:]))
    book.close()
    return rows


@pytest.fixture(scope="session")
def epw_path() -> Path:
    """The real Austin Camp Mabry TMY3 EPW (skips when ../shared/data is absent)."""
    return need(EPW)


@pytest.fixture(scope="session")
def resstock_weather_path() -> Path:
    """The real ResStock county weather CSV sample (skips when absent)."""
    return need(RESSTOCK_WEATHER)


@pytest.fixture(scope="session")
def workbook_path() -> Path:
    """The real ERCOT 2017 workbook (skips when absent)."""
    return need(WORKBOOK)


@pytest.fixture
def http_server():
    """Factory: serve a folder on 127.0.0.1; returns (base_url, state) where state['truncate'] is a set of
    URL paths answered with a full Content-Length but half the body, and state['requests'] lists GET paths."""
    import functools
    import http.server
    import threading

    servers = []

    def start(root: Path):
        state = {"truncate": set(), "requests": []}

        class Handler(http.server.SimpleHTTPRequestHandler):
            def log_message(self, *args):  # keep test output quiet
                pass

            def do_GET(self):  # noqa: N802 (http.server API)
                state["requests"].append(self.path)
                if self.path in state["truncate"]:
                    data = (root / self.path.lstrip("/")).read_bytes()
                    self.send_response(200)
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data[: len(data) // 2])
                    self.wfile.flush()
                    self.close_connection = True
                    return
                super().do_GET()

        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Handler, directory=str(root)))
        thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
        thread.start()
        servers.append(server)
        return f"http://127.0.0.1:{server.server_address[1]}", state

    yield start
    for server in servers:
        server.shutdown()
        server.server_close()

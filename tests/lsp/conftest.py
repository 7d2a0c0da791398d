"""The end-to-end tests of `eamos lsp`, driven by pytest-lsp: a language
client written by others (pygls), which also checks every answer against
the protocol.

`EAMOS_BIN` names the `eamos` binary (tests/lsp.rs sets it); the paper's
missions are read from `EAMOS_PAPER`, else `../shared/missions/paper` beside
the repository."""

import os
import pathlib

import pytest
import pytest_lsp
from lsprotocol import types
from pytest_lsp import ClientServerConfig, LanguageClient

HERE = pathlib.Path(__file__).resolve().parent
EAMOS = os.environ.get("EAMOS_BIN", "")
PAPER = pathlib.Path(
    os.environ.get("EAMOS_PAPER", HERE.parents[2] / "shared" / "missions" / "paper")
)

if not EAMOS:
    raise RuntimeError("EAMOS_BIN must name the eamos binary (run through tests/lsp.rs)")


@pytest_lsp.fixture(config=ClientServerConfig(server_command=[EAMOS, "lsp"]))
async def client(lsp_client: LanguageClient):
    params = types.InitializeParams(capabilities=types.ClientCapabilities())
    await lsp_client.initialize_session(params)
    yield
    await lsp_client.shutdown_session()


@pytest.fixture
def paper():
    return PAPER

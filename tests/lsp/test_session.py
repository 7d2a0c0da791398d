"""A mission author's session: open, type, hover, complete, jump, rename,
save; each answer asserted."""

import asyncio
import pathlib

from lsprotocol import types
from pytest_lsp import LanguageClient

DEADLOCK = """package Stuck

var D1 Quadcopter
var D2 Quadcopter

func PAR_Main() {
\tSEQ_One()
\tSEQ_Two()
}

func SEQ_One() {
\tAwait("b")
\tD1.Arm()
\tSignal("a")
}

func SEQ_Two() {
\tAwait("a")
\tD2.Arm()
\tSignal("b")
}
"""


def uri_of(path: pathlib.Path) -> str:
    return path.resolve().as_uri()


async def diagnostics_for(client: LanguageClient, uri: str, until=lambda d: True, timeout=30.0):
    """The diagnostics published for `uri`, once they satisfy `until`."""
    async def wait():
        while True:
            got = client.diagnostics.get(uri)
            if got is not None and until(got):
                return got
            try:
                await asyncio.wait_for(
                    client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS), 0.5
                )
            except asyncio.TimeoutError:
                pass

    return await asyncio.wait_for(wait(), timeout)


def codes(diagnostics):
    return [d.code for d in diagnostics]


def open_doc(client: LanguageClient, path: pathlib.Path, text: str, version=1):
    path.write_text(text)
    uri = uri_of(path)
    client.text_document_did_open(
        types.DidOpenTextDocumentParams(
            text_document=types.TextDocumentItem(uri=uri, language_id="go", version=version, text=text)
        )
    )
    return uri


def change(client: LanguageClient, uri: str, version: int, text: str):
    client.text_document_did_change(
        types.DidChangeTextDocumentParams(
            text_document=types.VersionedTextDocumentIdentifier(uri=uri, version=version),
            content_changes=[types.TextDocumentContentChangeWholeDocument(text=text)],
        )
    )


def position_of(text: str, needle: str, delta: int = 0) -> types.Position:
    at = text.index(needle) + delta
    line = text.count("\n", 0, at)
    col = at - (text.rfind("\n", 0, at) + 1)
    return types.Position(line=line, character=col)


def doc(uri):
    return types.TextDocumentIdentifier(uri=uri)


async def test_every_paper_mission_opens_without_diagnostics(client: LanguageClient, paper, tmp_path):
    missions = sorted(paper.glob("*.go"))
    assert missions, f"no paper missions in {paper}"
    for m in missions:
        uri = open_doc(client, tmp_path / m.name, m.read_text())
        got = await diagnostics_for(client, uri)
        assert len(got) == 0, f"{m.name}: {got}"


async def test_a_typo_is_reported_with_its_range_and_code_and_fixed_by_its_quick_fix(
    client: LanguageClient, paper, tmp_path
):
    text = (paper / "experiment_a.go").read_text()
    uri = open_doc(client, tmp_path / "a.go", text)
    assert len(await diagnostics_for(client, uri)) == 0
    typo = text.replace("Drone1.FlyByX(1)", "Drone1.FlyBX(1)", 1)
    change(client, uri, 2, typo)
    got = await diagnostics_for(client, uri, lambda d: len(d) > 0)
    assert len(got) == 1, got
    d = got[0]
    assert d.code == "eamos::unknown-action"
    assert d.severity == types.DiagnosticSeverity.Error
    start = position_of(typo, "FlyBX")
    assert d.range.start == start
    assert d.range.end == types.Position(line=start.line, character=start.character + len("FlyBX"))
    assert "did you mean `FlyByX`?" in d.message
    actions = await client.text_document_code_action_async(
        types.CodeActionParams(
            text_document=doc(uri),
            range=d.range,
            context=types.CodeActionContext(diagnostics=[d]),
        )
    )
    assert len(actions) == 1
    edit = actions[0].edit.changes[uri][0]
    assert edit.new_text == "FlyByX" and edit.range == d.range


async def test_hover_shows_an_actions_parameters_and_units_and_a_blocks_kind(
    client: LanguageClient, paper, tmp_path
):
    text = (paper / "experiment_a.go").read_text()
    uri = open_doc(client, tmp_path / "a.go", text)
    hover = await client.text_document_hover_async(
        types.HoverParams(text_document=doc(uri), position=position_of(text, "Takeoff", 2))
    )
    assert "height" in hover.contents.value and "metres" in hover.contents.value
    hover = await client.text_document_hover_async(
        types.HoverParams(text_document=doc(uri), position=position_of(text, "SEQ_Experiment_A", 3))
    )
    assert "SEQ block" in hover.contents.value and "Drone1" in hover.contents.value


async def test_completion_offers_a_drones_actions_with_snippets_and_the_events(
    client: LanguageClient, tmp_path
):
    uri = open_doc(client, tmp_path / "d.go", DEADLOCK)
    typed = DEADLOCK.replace("\tD1.Arm()\n", "\tD1.Arm()\n\tD1.\n", 1)
    change(client, uri, 2, typed)
    at = position_of(typed, "\tD1.\n", 4)
    items = await client.text_document_completion_async(
        types.CompletionParams(text_document=doc(uri), position=at)
    )
    items = items.items if hasattr(items, "items") else items
    by_label = {i.label: i for i in items}
    assert "Takeoff" in by_label and "Battery" in by_label, sorted(by_label)
    assert by_label["Takeoff"].insert_text == "Takeoff(${1:height})"
    assert by_label["Takeoff"].insert_text_format == types.InsertTextFormat.Snippet
    typed = DEADLOCK.replace('Await("b")', 'Await("")', 1)
    change(client, uri, 3, typed)
    items = await client.text_document_completion_async(
        types.CompletionParams(text_document=doc(uri), position=position_of(typed, 'Await("")', 7))
    )
    items = items.items if hasattr(items, "items") else items
    assert {i.label for i in items} == {"a", "b"}
    items = await client.text_document_completion_async(
        types.CompletionParams(text_document=doc(uri), position=types.Position(line=7, character=1))
    )
    items = items.items if hasattr(items, "items") else items
    labels = {i.label for i in items}
    assert {"D1", "SEQ_One", "RepeatFor", "If", "Signal"} <= labels


async def test_an_await_goes_to_its_signal_and_references_find_both(client: LanguageClient, tmp_path):
    uri = open_doc(client, tmp_path / "d.go", DEADLOCK)
    await_b = position_of(DEADLOCK, 'Await("b")', 7)
    got = await client.text_document_definition_async(
        types.DefinitionParams(text_document=doc(uri), position=await_b)
    )
    assert len(got) == 1
    assert got[0].range.start == position_of(DEADLOCK, 'Signal("b")', 8)
    refs = await client.text_document_references_async(
        types.ReferenceParams(
            text_document=doc(uri),
            position=await_b,
            context=types.ReferenceContext(include_declaration=True),
        )
    )
    assert len(refs) == 2
    block = await client.text_document_definition_async(
        types.DefinitionParams(text_document=doc(uri), position=position_of(DEADLOCK, "\tSEQ_Two()", 2))
    )
    assert block[0].range.start == position_of(DEADLOCK, "SEQ_Two() {")


async def test_renaming_a_block_edits_its_declaration_and_every_call(client: LanguageClient, tmp_path):
    uri = open_doc(client, tmp_path / "d.go", DEADLOCK)
    edit = await client.text_document_rename_async(
        types.RenameParams(
            text_document=doc(uri),
            position=position_of(DEADLOCK, "SEQ_One() {", 1),
            new_name="SEQ_First",
        )
    )
    edits = edit.changes[uri]
    assert len(edits) == 2
    assert all(e.new_text == "SEQ_First" for e in edits)
    assert {e.range.start.line for e in edits} == {6, 10}


async def test_the_outline_lists_drones_and_blocks(client: LanguageClient, tmp_path):
    uri = open_doc(client, tmp_path / "d.go", DEADLOCK)
    symbols = await client.text_document_document_symbol_async(
        types.DocumentSymbolParams(text_document=doc(uri))
    )
    assert [s.name for s in symbols] == ["D1", "D2", "PAR_Main", "SEQ_One", "SEQ_Two"]
    assert symbols[2].detail == "PAR"


async def test_a_deadlock_is_found_on_save_with_its_counterexample(client: LanguageClient, tmp_path):
    uri = open_doc(client, tmp_path / "d.go", DEADLOCK)
    got = await diagnostics_for(client, uri)
    assert "check::deadlock" not in codes(got), "the check runs on save, not on open"
    client.text_document_did_save(types.DidSaveTextDocumentParams(text_document=doc(uri)))
    got = await diagnostics_for(client, uri, lambda d: "check::deadlock" in codes(d))
    d = next(d for d in got if d.code == "check::deadlock")
    assert d.severity == types.DiagnosticSeverity.Error
    assert d.range.start.line in (11, 17), d.range
    assert d.related_information, "the counterexample comes as related information"
    assert any("counterexample" in r.message for r in d.related_information)


async def test_the_fleet_file_beside_the_mission_gives_the_airspace_on_save(
    client: LanguageClient, paper, tmp_path
):
    # A 10 m ceiling: experiment A's 1.5 m take-off is fine, a 40 m one is not.
    (tmp_path / "fleet.toml").write_text("[airspace]\nceiling = 10.0\n")
    text = (paper / "experiment_a.go").read_text().replace("Takeoff(1.5)", "Takeoff(40)")
    uri = open_doc(client, tmp_path / "a.go", text)
    assert len(await diagnostics_for(client, uri)) == 0
    client.text_document_did_save(types.DidSaveTextDocumentParams(text_document=doc(uri)))
    got = await diagnostics_for(client, uri, lambda d: len(d) > 0)
    assert all(d.code.startswith("check::") for d in got), codes(got)
    takeoff = position_of(text, "Takeoff(40)")
    assert any(d.range.start.line == takeoff.line for d in got), got


async def test_an_events_hover_names_its_sites_and_rename_keeps_its_quotes(
    client: LanguageClient, tmp_path
):
    uri = open_doc(client, tmp_path / "d.go", DEADLOCK)
    at = position_of(DEADLOCK, 'Await("a")', 7)
    hover = await client.text_document_hover_async(types.HoverParams(text_document=doc(uri), position=at))
    signal_line = position_of(DEADLOCK, 'Signal("a")').line + 1
    await_line = at.line + 1
    assert f"`Signal` at line {signal_line}" in hover.contents.value, hover.contents.value
    assert f"`Await` at line {await_line}" in hover.contents.value, hover.contents.value
    edit = await client.text_document_rename_async(
        types.RenameParams(text_document=doc(uri), position=at, new_name="airborne")
    )
    edits = edit.changes[uri]
    assert len(edits) == 2 and all(e.new_text == "airborne" for e in edits)
    for e in edits:
        line = DEADLOCK.splitlines()[e.range.start.line]
        assert line[e.range.start.character - 1] == '"' and line[e.range.end.character] == '"'

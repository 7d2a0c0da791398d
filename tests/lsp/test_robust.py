"""A client that misbehaves: malformed bodies, unknown methods, files that
are not missions, a client gone mid-request. The server answers what can be
answered and keeps serving; it never crashes. These speak the wire format
directly, since no well-behaved client sends such things."""

import json
import os
import queue
import subprocess
import threading

from conftest import EAMOS


class Raw:
    """`eamos lsp` on pipes, with its messages read on a thread."""

    def __init__(self):
        self.proc = subprocess.Popen(
            [EAMOS, "lsp"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE
        )
        self.inbox = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.next_id = 0

    def _read(self):
        out = self.proc.stdout
        while True:
            length = None
            while True:
                line = out.readline()
                if not line:
                    return
                line = line.strip()
                if not line:
                    break
                name, _, value = line.partition(b":")
                if name.lower() == b"content-length":
                    length = int(value)
            self.inbox.put(json.loads(out.read(length)))

    def send_bytes(self, body: bytes):
        self.proc.stdin.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
        self.proc.stdin.flush()

    def send(self, msg: dict):
        self.send_bytes(json.dumps({"jsonrpc": "2.0", **msg}).encode())

    def request(self, method, params):
        self.next_id += 1
        self.send({"id": self.next_id, "method": method, "params": params})
        return self.answer(self.next_id)

    def answer(self, id, timeout=10):
        while True:
            msg = self.inbox.get(timeout=timeout)
            if msg.get("id") == id and "method" not in msg:
                return msg

    def diagnostics(self, uri, timeout=10):
        while True:
            msg = self.inbox.get(timeout=timeout)
            if msg.get("method") == "textDocument/publishDiagnostics" and msg["params"]["uri"] == uri:
                return msg["params"]["diagnostics"]

    def initialize(self):
        got = self.request("initialize", {"processId": os.getpid(), "rootUri": None, "capabilities": {}})
        assert "capabilities" in got["result"]
        self.send({"method": "initialized", "params": {}})

    def open(self, uri, text):
        doc = {"uri": uri, "languageId": "go", "version": 1, "text": text}
        self.send({"method": "textDocument/didOpen", "params": {"textDocument": doc}})

    def still_serves(self):
        got = self.request("textDocument/hover", {
            "textDocument": {"uri": "file:///nothing.go"}, "position": {"line": 0, "character": 0}})
        assert got.get("result") is None and "error" not in got, got

    def close(self):
        self.request("shutdown", None)
        self.send({"method": "exit"})
        assert self.proc.wait(timeout=10) == 0
        stderr = self.proc.stderr.read().decode()
        assert "panicked" not in stderr, stderr


def test_a_malformed_body_is_a_parse_error_and_the_server_keeps_serving():
    s = Raw()
    s.initialize()
    s.send_bytes(b"{this is not json")
    got = s.answer(None)
    assert got["error"]["code"] == -32700
    s.send_bytes(b'{"jsonrpc": "2.0", "id": 77, "method": 5}')
    assert s.answer(77)["error"]["code"] == -32600
    s.proc.stdin.write(b"Content-Length: nine\r\n\r\n")
    s.proc.stdin.flush()
    s.still_serves()
    s.close()


def test_an_unknown_method_is_method_not_found_and_bad_params_are_invalid_params():
    s = Raw()
    s.initialize()
    assert s.request("eamos/teleport", {})["error"]["code"] == -32601
    s.send({"method": "eamos/unheard-of", "params": {}})
    got = s.request("textDocument/hover", {"textDocument": "not an object"})
    assert got["error"]["code"] == -32602
    got = s.request("textDocument/rename", {
        "textDocument": {"uri": "file:///x.go"}, "position": {"line": -1, "character": 0}, "newName": 3})
    assert "error" in got
    s.still_serves()
    s.close()


def test_a_request_before_initialize_is_refused_not_fatal():
    s = Raw()
    got = s.request("textDocument/hover", {})
    assert got["error"]["code"] == -32002
    s.initialize()
    s.still_serves()
    s.close()


def test_files_that_are_not_missions_get_diagnostics_not_a_crash():
    s = Raw()
    s.initialize()
    texts = {
        "file:///robust/main.go": 'package main\n\nimport "fmt"\n\nfunc main() { fmt.Println("hi") }\n',
        "file:///robust/notes.txt": "\x00\x01 {{{ ((( \"unclosed\n/* and more",
        "file:///robust/empty.go": "",
        "file:///robust/deep.go": "package M\nfunc INIT() { If(" + "(" * 5000 + "\n",
    }
    for uri, text in texts.items():
        s.open(uri, text)
        assert isinstance(s.diagnostics(uri), list)
        for line in range(3):
            for method in ("textDocument/hover", "textDocument/completion", "textDocument/definition"):
                got = s.request(method, {"textDocument": {"uri": uri}, "position": {"line": line, "character": 3}})
                assert "error" not in got, (uri, method, got)
    s.still_serves()
    s.close()


def test_a_client_gone_mid_request_lets_the_server_exit_cleanly():
    s = Raw()
    s.initialize()
    s.open("file:///robust/m.go", "package M\nvar D1 Quadcopter\nfunc INIT() { D1.Arm() }\n")
    s.diagnostics("file:///robust/m.go")
    body = json.dumps({"jsonrpc": "2.0", "id": 9, "method": "textDocument/hover", "params": {}}).encode()
    s.proc.stdin.write(b"Content-Length: %d\r\n\r\n" % len(body) + body[:20])
    s.proc.stdin.flush()
    s.proc.stdin.close()
    assert s.proc.wait(timeout=10) == 0
    assert "panicked" not in s.proc.stderr.read().decode()

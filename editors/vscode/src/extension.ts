// Starts `eamos lsp` for mission files, and only for them: Go files that
// are not missions never reach it (every message about a document passes
// the `isMission` filter below), so Go's own tools keep them.

import * as vscode from "vscode";
import {
  LanguageClient,
  LanguageClientOptions,
  Middleware,
  ServerOptions,
} from "vscode-languageclient/node";
import { hasMissionShape } from "./mission";

let client: LanguageClient | undefined;
const missions = new Set<string>();

function isMission(doc: vscode.TextDocument): boolean {
  if (doc.uri.scheme !== "file" && doc.uri.scheme !== "untitled") {
    return false;
  }
  const pattern = vscode.workspace.getConfiguration("eamos").get<string>("missionPattern", "");
  const mission = pattern
    ? vscode.languages.match({ pattern }, doc) > 0
    : doc.languageId === "go" && hasMissionShape(doc.getText());
  const key = doc.uri.toString();
  if (mission) {
    missions.add(key);
  } else {
    missions.delete(key);
  }
  return mission;
}

// Every hook that carries a document asks the filter first.
const middleware: Middleware = {
  didOpen: (doc, next) => (isMission(doc) ? next(doc) : Promise.resolve()),
  didChange: (e, next) => {
    const was = missions.has(e.document.uri.toString());
    return was && isMission(e.document) ? next(e) : Promise.resolve();
  },
  didSave: (doc, next) => (missions.has(doc.uri.toString()) ? next(doc) : Promise.resolve()),
  didClose: (doc, next) => {
    const was = missions.delete(doc.uri.toString());
    return was ? next(doc) : Promise.resolve();
  },
  provideHover: (doc, pos, token, next) => (isMission(doc) ? next(doc, pos, token) : null),
  provideCompletionItem: (doc, pos, ctx, token, next) =>
    isMission(doc) ? next(doc, pos, ctx, token) : null,
  provideDefinition: (doc, pos, token, next) => (isMission(doc) ? next(doc, pos, token) : null),
  provideReferences: (doc, pos, ctx, token, next) =>
    isMission(doc) ? next(doc, pos, ctx, token) : null,
  prepareRename: (doc, pos, token, next) => (isMission(doc) ? next(doc, pos, token) : null),
  provideRenameEdits: (doc, pos, name, token, next) =>
    isMission(doc) ? next(doc, pos, name, token) : null,
  provideDocumentSymbols: (doc, token, next) => (isMission(doc) ? next(doc, token) : null),
  provideCodeActions: (doc, range, ctx, token, next) =>
    isMission(doc) ? next(doc, range, ctx, token) : null,
};

function start(): void {
  if (client) {
    return;
  }
  const config = vscode.workspace.getConfiguration("eamos");
  const command = config.get<string>("path", "eamos");
  const pattern = config.get<string>("missionPattern", "");
  const server: ServerOptions = { command, args: ["lsp"] };
  const options: LanguageClientOptions = {
    documentSelector: [
      { scheme: "file", language: "go" },
      { scheme: "untitled", language: "go" },
      ...(pattern ? [{ pattern }] : []),
    ],
    initializationOptions: { fleet: config.get<string>("fleet", "") },
    synchronize: { configurationSection: "eamos" },
    middleware,
  };
  client = new LanguageClient("eamos", "EAMOS missions", server, options);
  void client.start();
}

export function activate(context: vscode.ExtensionContext): void {
  // The server starts with the first mission, not with the first Go file.
  const consider = (doc: vscode.TextDocument) => {
    if (isMission(doc)) {
      start();
    }
  };
  vscode.workspace.textDocuments.forEach(consider);
  context.subscriptions.push(
    vscode.workspace.onDidOpenTextDocument(consider),
    vscode.workspace.onDidChangeTextDocument((e) => consider(e.document)),
  );
}

export function deactivate(): Thenable<void> | undefined {
  return client?.stop();
}

// The VS Code side of sgt: starts `sgt lsp` for .sgt files (vscode-languageclient) and adds
// "sgt: Preview the utterance at the cursor", which asks the server to render a GIF
// (the server's sgt.preview command) and opens it beside the script.
"use strict";
const vscode = require("vscode");
const { LanguageClient } = require("vscode-languageclient/node");

let client;

function activate(context) {
  const config = vscode.workspace.getConfiguration("sgt");
  const [command, ...args] = config.get("command", ["sgt", "lsp"]);
  client = new LanguageClient(
    "sgt",
    "sgt language server",
    { command, args },
    { documentSelector: [{ scheme: "file", language: "sgt" }, { scheme: "untitled", language: "sgt" }] },
  );
  context.subscriptions.push(
    vscode.commands.registerCommand("sgt.previewUtterance", async () => {
      const editor = vscode.window.activeTextEditor;
      if (!editor || editor.document.languageId !== "sgt") {
        return;
      }
      const engine = vscode.workspace.getConfiguration("sgt").get("previewEngine") || undefined;
      const request = { uri: editor.document.uri.toString(), line: editor.selection.active.line, engine };
      try {
        const result = await vscode.window.withProgress(
          { location: vscode.ProgressLocation.Notification, title: "sgt: rendering the utterance..." },
          () => vscode.commands.executeCommand("sgt.preview", request),
        );
        await vscode.commands.executeCommand("vscode.open", vscode.Uri.file(result.gif), vscode.ViewColumn.Beside);
      } catch (err) {
        vscode.window.showWarningMessage(`sgt preview: ${err.message || err}`);
      }
    }),
  );
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };

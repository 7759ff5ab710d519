// A test host for robocog's robot app, built from ext-apps' AppBridge (the host side of MCP Apps):
// it renders the app's page in a sandboxed iframe (scripts only: no same origin, no forms, no popups)
// under the CSP its resource's `_meta.ui.csp` asks for, relays tool inputs and results to it, and
// answers the page's tool calls through `window.hostCallTool`, which the test binds to the official
// MCP SDK's client of a real robocog-server. `node assets/app/build.mjs --host OUT` bundles it.
import { AppBridge, PostMessageTransport } from "@modelcontextprotocol/ext-apps/app-bridge";

// The CSP a host builds from `_meta.ui.csp`: the page's own inline script and styles, pictures from
// data: URLs, and only the origins it names (none for robocog's).
function policy(csp) {
  const list = (xs) => (xs && xs.length ? " " + xs.join(" ") : "");
  const res = list(csp && csp.resourceDomains);
  return [
    "default-src 'none'",
    `script-src 'unsafe-inline'${res}`,
    `style-src 'unsafe-inline'${res}`,
    `img-src data:${res}`,
    `font-src${res || " 'none'"}`,
    `connect-src${list(csp && csp.connectDomains) || " 'none'"}`,
    `frame-src${list(csp && csp.frameDomains) || " 'none'"}`,
    `base-uri${list(csp && csp.baseUriDomains) || " 'none'"}`,
  ].join("; ");
}

const host = {
  bridge: null, frame: null, calls: [], relayed: [], violations: [],
  async load(html, meta) {
    const csp = meta && meta.ui ? meta.ui.csp : undefined;
    const tag = `<meta http-equiv="Content-Security-Policy" content="${policy(csp)}">`;
    const frame = document.createElement("iframe");
    frame.setAttribute("sandbox", "allow-scripts");
    frame.id = "app";
    frame.srcdoc = html.replace(/<head>/i, `<head>${tag}`);
    document.getElementById("slot").append(frame);
    this.frame = frame;
    const bridge = new AppBridge(null, { name: "robocog test host", version: "1.0.0" }, { serverTools: {}, logging: {} });
    bridge.oncalltool = async (params) => {
      this.calls.push(params.name);
      return JSON.parse(await window.hostCallTool(JSON.stringify(params)));
    };
    bridge.onsizechange = () => {};
    bridge.onloggingmessage = () => {};
    const ready = new Promise((resolve) => { bridge.oninitialized = resolve; });
    await bridge.connect(new PostMessageTransport(frame.contentWindow, frame.contentWindow));
    this.bridge = bridge;
    await ready;
  },
  // One tool call's input then result, as a host hands them to the page; returns when the result was
  // posted to the page (performance.timeOrigin + performance.now(), ms since the epoch).
  async relay(input, result) {
    await this.bridge.sendToolInput({ arguments: input });
    const sent = performance.timeOrigin + performance.now();
    await this.bridge.sendToolResult(result);
    this.relayed.push(sent);
    return sent;
  },
};
document.addEventListener("securitypolicyviolation", (e) => host.violations.push(e.violatedDirective));
window.robocogHost = host;

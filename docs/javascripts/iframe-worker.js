// A Web Worker for pages opened from disk (file://), where Chromium and Firefox refuse `new Worker`
// on a file URL: the worker's script runs in a hidden same-origin iframe instead, and messages pass
// by direct calls. Material's search runs its index in a worker; with this, search works from disk.
// Named "iframe-worker" so Material's offline plugin does not add its own copy from a CDN (unpkg).
(function () {
  "use strict";
  if (location.protocol !== "file:" || typeof window.Worker !== "function") return;

  function FileWorker(url) {
    var worker = this;
    var events = document.createElement("span"); // an EventTarget the page listens on
    var inner = null;
    var waiting = [];
    worker.onmessage = null;
    worker.onerror = null;
    worker.addEventListener = events.addEventListener.bind(events);
    worker.removeEventListener = events.removeEventListener.bind(events);
    worker.dispatchEvent = events.dispatchEvent.bind(events);

    function toPage(type, init) {
      var event = type === "message" ? new MessageEvent("message", init) : new ErrorEvent("error", init);
      var handler = type === "message" ? worker.onmessage : worker.onerror;
      if (typeof handler === "function") handler.call(worker, event);
      events.dispatchEvent(event);
    }
    function toWorker(data) {
      inner.dispatchEvent(new inner.MessageEvent("message", { data: data }));
    }
    worker.postMessage = function (data) {
      if (inner) toWorker(data);
      else waiting.push(data);
    };
    worker.terminate = function () {
      frame.remove();
      inner = null;
    };

    var frame = document.createElement("iframe");
    frame.hidden = true;
    frame.setAttribute("aria-hidden", "true");
    frame.srcdoc = "<!doctype html><title>worker</title>";
    frame.addEventListener("load", function () {
      var w = frame.contentWindow;
      var base = new URL(url, location.href);
      w.postMessage = function (data) { toPage("message", { data: data }); };
      w.close = function () { worker.terminate(); };
      w.importScripts = function () {
        // Only at start-up in Material's worker (extra languages); loaded in order before its messages.
        Array.prototype.forEach.call(arguments, function (src) {
          var s = w.document.createElement("script");
          s.src = new URL(src, base).href;
          s.async = false;
          w.document.head.appendChild(s);
        });
      };
      var script = w.document.createElement("script");
      script.src = base.href;
      script.onload = function () {
        inner = w;
        waiting.splice(0).forEach(toWorker);
      };
      script.onerror = function () { toPage("error", { message: "cannot load worker " + base.href }); };
      w.document.head.appendChild(script);
    });
    (document.body || document.documentElement).appendChild(frame);
  }
  window.Worker = FileWorker;
})();

// The site's service worker (make site): every file of the page is kept at install, and each
// request goes to the network first (so a new version is what the next load gets) and to the
// kept copy when the network is not there (offline, or the static server stopped). The network
// is asked past the HTTP cache ("no-cache": a conditional request, 304 when nothing changed),
// or a heuristically fresh old file would hide the new version.
const VERSION = "__VERSION__";
const FILES = __FILES__;
const CACHE = `nurimc-site-${VERSION}`;

self.addEventListener("install", (event) => {
  event.waitUntil(
    caches
      .open(CACHE)
      .then((cache) => cache.addAll(FILES))
      .then(() => self.skipWaiting()),
  );
});

self.addEventListener("activate", (event) => {
  event.waitUntil(
    caches
      .keys()
      .then((keys) =>
        Promise.all(keys.filter((k) => k.startsWith("nurimc-site-") && k !== CACHE).map((k) => caches.delete(k))),
      )
      .then(() => self.clients.claim()),
  );
});

self.addEventListener("fetch", (event) => {
  const request = event.request;
  if (request.method !== "GET" || new URL(request.url).origin !== self.location.origin) return;
  event.respondWith(
    fetch(request.url, { cache: "no-cache", credentials: "same-origin" })
      .then((response) => {
        if (response.ok) {
          const copy = response.clone();
          caches.open(CACHE).then((cache) => cache.put(request, copy));
        }
        return response;
      })
      .catch(async () => {
        const kept = await caches.match(request, { ignoreSearch: true });
        if (kept) return kept;
        if (request.mode === "navigate") return (await caches.match("./index.html")) ?? Response.error();
        return Response.error();
      }),
  );
});

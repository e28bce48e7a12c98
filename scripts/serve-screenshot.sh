#!/usr/bin/env bash
# The gallery's picture of the live page (docs/images/serve.png): `raycast serve` of the course
# bunny with the toon hook, in headless Chromium driven by chromedriver, after a drag.
# Usage: scripts/serve-screenshot.sh [OUT.png]  (RAYCAST: the binary, target/release/raycast)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/images/serve.png}
raycast=${RAYCAST:-target/release/raycast}
port=8437
driver=9517
"$raycast" serve scenes/course/bunny.json --shader shaders/examples/toon.wgsl --port "$port" >/dev/null &
server=$!
chromedriver --port="$driver" >/dev/null 2>&1 &
chrome=$!
profile=$(mktemp -d)
trap 'kill "$server" "$chrome" 2>/dev/null; rm -rf "$profile"' EXIT

webdriver() { # METHOD PATH [JSON]
    curl -sf -X "$1" -H 'Content-Type: application/json' ${3:+-d "$3"} "http://127.0.0.1:$driver$2"
}
value() { python3 -c "import json,sys; print(json.load(sys.stdin)['value']$1)"; }
until curl -sf "http://127.0.0.1:$port/state" >/dev/null; do sleep 0.2; done
until webdriver GET /status >/dev/null; do sleep 0.2; done

args='"--headless=new","--no-sandbox","--disable-gpu","--disable-quic","--no-first-run","--disable-background-networking","--disable-component-update","--disable-sync","--window-size=1000,720","--user-data-dir='"$profile"'"'
session=$(webdriver POST /session '{"capabilities":{"alwaysMatch":{"goog:chromeOptions":{"binary":"/usr/bin/chromium","args":['"$args"']}}}}' | value "['sessionId']")
s=/session/$session
webdriver POST "$s/url" '{"url":"http://127.0.0.1:'"$port"'/"}' >/dev/null
settled='{"script":"const r = window.raycast; return !!(r && r.frames > 0 && !r.busy && document.getElementById(\"picture\").dataset.query.includes(\"size=640x360\"));","args":[]}'
until [ "$(webdriver POST "$s/execute/sync" "$settled" | value '')" = True ]; do sleep 0.2; done
element=$(webdriver POST "$s/element" '{"using":"css selector","value":"#picture"}' | value ".popitem()[1]")
webdriver POST "$s/actions" '{"actions":[{"type":"pointer","id":"mouse","parameters":{"pointerType":"mouse"},"actions":[
  {"type":"pointerMove","duration":0,"origin":{"element-6066-11e4-a52e-4f735466cecf":"'"$element"'"},"x":0,"y":0},
  {"type":"pointerDown","button":0},{"type":"pointerMove","duration":400,"origin":"pointer","x":-90,"y":25},
  {"type":"pointerUp","button":0}]}]}' >/dev/null
sleep 1
until [ "$(webdriver POST "$s/execute/sync" "$settled" | value '')" = True ]; do sleep 0.2; done
webdriver GET "$s/screenshot" | python3 -c "import base64,json,sys; sys.stdout.buffer.write(base64.b64decode(json.load(sys.stdin)['value']))" >"$out.tmp"
mv "$out.tmp" "$out"
webdriver DELETE "$s" >/dev/null
echo "wrote $out"

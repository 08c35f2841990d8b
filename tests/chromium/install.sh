#!/usr/bin/env bash
# Debian's headless-capable Chromium for the report test (opt-in: WAAMTWIN_SYSTEM_TESTS=1).
# Idempotent; installs as root from the distribution's packages. Prints the browser's path.
set -euo pipefail
if ! command -v chromium >/dev/null 2>&1; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null
    apt-get install -y -qq chromium >/dev/null
fi
command -v chromium

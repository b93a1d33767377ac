#!/usr/bin/env bash
# THE run command: ./scripts/run.sh
#
# Installs what it needs (Python packages into .venv; Redis, Mosquitto (MQTT, for VDA 5050
# vehicles), and PostgreSQL when DATABASE_URL names a local one, from Debian's packages when
# missing), prepares the database and static
# files, loads the hospital site, then runs every process of the Procfile under honcho in the
# foreground. Ctrl-C stops them all.
#
# Environment: DATABASE_URL (default: SQLite file db.sqlite3), REDIS_URL, PORT_HTTP (8000),
# PORT_WS (8001), PORT_WEB (8002), PORT_WEB_WOKEN (8003), WEB_WORKERS (3), SITE_FILE (sites/eulji.yaml), SECRET_KEY (default: generated
# once into var/secret_key), METRICS_TOKEN (a bearer token for Prometheus to scrape /metrics),
# PROMETHEUS_MULTIPROC_DIR (var/prometheus, emptied on every start).
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
# shellcheck source=scripts/lib.sh
source scripts/lib.sh

# One port for everything (nginx); gunicorn and daphne listen behind it, on loopback.
export PORT_HTTP="${PORT_HTTP:-8000}"
export PORT_WS="${PORT_WS:-8001}"
export PORT_WEB="${PORT_WEB:-8002}"
export PORT_WEB_WOKEN="${PORT_WEB_WOKEN:-8003}"  # gunicorn's socket for woken heartbeats
SITE_FILE="${SITE_FILE:-sites/eulji.yaml}"

# is_local_url URL DEFAULT_PORT: URL points at this machine on DEFAULT_PORT (what we can start).
is_local_url() {
    local url="$1" port="$2"
    [[ "${url}" =~ ^[a-z0-9+]+://([^/@]*@)?(127\.0\.0\.1|localhost)(:${port})?(/|$) ]]
}

ensure_services() {
    if [[ "${BUILDING_ADAPTER:-sim}" == "mqtt" && "${BUILDING_MQTT_HOST:-127.0.0.1}" == "127.0.0.1" ]]; then
        ensure_mosquitto  # the building's lift and door controllers talk to it
    fi
    if [[ -z "${REDIS_URL:-}" ]] || is_local_url "${REDIS_URL}" 6379; then
        ensure_redis
    else
        log "REDIS_URL is not local; not starting Redis"
    fi
    case "${VDA5050_MQTT_HOST:-127.0.0.1}:${VDA5050_MQTT_PORT:-1883}" in
        127.0.0.1:1883 | localhost:1883) ensure_mosquitto ;;
        *) log "VDA5050_MQTT_HOST/PORT is not the local broker; not starting Mosquitto" ;;
    esac
    case "${DATABASE_URL:-}" in
        postgres://* | postgresql://* | pgsql://*)
            if is_local_url "${DATABASE_URL}" 5432; then
                ensure_postgres
                ensure_local_postgres_database
            fi
            ;;
    esac
}

# With DATABASE_URL=postgres://USER:PASSWORD@127.0.0.1:5432/NAME, create USER and NAME when
# missing, so a fresh machine needs nothing by hand.
ensure_local_postgres_database() {
    local parts user password dbname
    parts="$(python - "${DATABASE_URL}" <<'PY'
import sys
from urllib.parse import unquote, urlsplit

url = urlsplit(sys.argv[1])
print(unquote(url.username or ""), unquote(url.password or ""), unquote(url.path.lstrip("/")))
PY
)"
    read -r user password dbname <<<"${parts}"
    if [[ -n "${user}" && -n "${password}" && -n "${dbname}" ]]; then
        ensure_postgres_database "${user}" "${password}" "${dbname}"
    fi
}

ensure_secret_key() {
    if [[ -n "${SECRET_KEY:-}" ]]; then
        return 0
    fi
    local file=var/secret_key
    if [[ ! -s "${file}" ]]; then
        log "generating ${file}"
        (
            umask 077
            python -c 'import secrets; print(secrets.token_urlsafe(50))' >"${file}.tmp"
        )
        mv "${file}.tmp" "${file}"
    fi
    chmod 600 "${file}"
    SECRET_KEY="$(cat "${file}")"
    export SECRET_KEY
}

check_ports_free() {
    local port
    for port in "${PORT_HTTP}" "${PORT_WS}" "${PORT_WEB}" "${PORT_WEB_WOKEN}"; do
        if tcp_port_open 127.0.0.1 "${port}"; then
            die "port ${port} on 127.0.0.1 is already in use (another ./scripts/run.sh?); set PORT_HTTP/PORT_WS/PORT_WEB/PORT_WEB_WOKEN to use others"
        fi
    done
}

# ---------------------------------------------------------------------------------------------
# HOOKS: later work fills these in. Each runs after migrate/collectstatic/load_site, before the
# processes start, and must be idempotent (run.sh runs them on every start).

# HOOK demo users: create the demo accounts (e.g. an admin and a ward nurse) when missing.
# Groups nurse and operator, users admin/operator/nurse; passwords generated once into
# var/demo_logins.json (mode 600) and printed on every start.
hook_create_demo_users() {
    python manage.py demo_setup --only users >/dev/null  # printed last, once the page answers
}

# HOOK robot tokens: issue API tokens for the simulated robots (e.g. into var/), for the fleet.
# New tokens for the site's robots and the request generator's user, with the server's URLs,
# into var/fleet.json (mode 600), which the fleet process reads.
# FLEET_VDA5050 (default 0.5): the share of the robots declared VDA 5050 vehicles, which the
# fleet runs over MQTT and the `vda5050` bridge makes members of the fleet (a mixed fleet).
hook_issue_robot_tokens() {
    python manage.py demo_setup --only fleet --site-file "${SITE_FILE}" \
        --server-url "http://127.0.0.1:${PORT_HTTP}" --ws-url "ws://127.0.0.1:${PORT_HTTP}" \
        --vda5050 "${FLEET_VDA5050:-0.5}"
}

# HOOK simulated fleet: prepare whatever the `fleet:` Procfile line needs. The fleet process
# itself is started by honcho: add a `fleet:` line to the Procfile.
# FLEET_SPEEDUP (default 20: a delivery across floors takes well under a minute of real time)
# and FLEET_TRAFFIC (random deliveries per simulated hour, default 6) tune it.
hook_prepare_fleet() {
    export FLEET_SPEEDUP="${FLEET_SPEEDUP:-20}"
    export FLEET_TRAFFIC="${FLEET_TRAFFIC:-6}"
    [[ -s var/fleet.json ]] || die "var/fleet.json is missing (demo_setup did not write it)"
}
# ---------------------------------------------------------------------------------------------

mkdir -p var
chmod 700 var
ensure_venv
ensure_services
ensure_nginx
# From here on (after apt and the services' setup), files this script and the servers create
# (var/, db.sqlite3, collected static files) are the owner's alone.
umask 077
ensure_secret_key
check_ports_free
# Every process's log lines in one zone, the site's (settings.TIME_ZONE): Django sets it in its
# own processes, TZ gives it to nginx, honcho's line prefix and gunicorn's master too.
TZ="$(python -c 'import os; os.environ["DJANGO_SETTINGS_MODULE"] = "hospital_delivery.settings"
from django.conf import settings; print(settings.TIME_ZONE)')"
export TZ

log "migrating the database"
python manage.py migrate --noinput
log "collecting static files"
python manage.py collectstatic --noinput -v 0
log "compiling the translations"
compile_catalogs
log "writing the proxy's configuration"
python manage.py proxy_config --listen "127.0.0.1:${PORT_HTTP}" --web "127.0.0.1:${PORT_WEB}" \
    --web-woken "127.0.0.1:${PORT_WEB_WOKEN}" --ws "127.0.0.1:${PORT_WS}" --runtime var/nginx >/dev/null
log "loading site ${SITE_FILE}"
python manage.py load_site "${SITE_FILE}"

hook_create_demo_users
hook_issue_robot_tokens
hook_prepare_fleet

# The banner once the login page answers through the proxy (not while it still says 502) and a
# sweep has run (Celery's worker and beat are up, their start-up lines printed), with the demo
# logins last: below them the terminal shows only deliveries, alerts and errors.
announce_when_up() {
    local logins
    logins="$(python manage.py demo_setup --only users)"
    if python - "http://127.0.0.1:${PORT_WEB}" "http://127.0.0.1:${PORT_HTTP}" <<'PY'; then
import json
import sys
import time
import urllib.error
import urllib.request


def answer(url):
    try:
        with urllib.request.urlopen(url, timeout=2) as response:
            return response.status, response.read()
    except urllib.error.HTTPError as error:  # /healthz says 503 until every sweep has run
        return error.code, error.read()
    except OSError:
        return None, b""


# gunicorn itself first (asking the proxy before would only fill its error log with 502s).
web, proxy = sys.argv[1:3]
deadline = time.monotonic() + 300
while time.monotonic() < deadline:
    health, body = answer(f"{web}/healthz")
    if health in (200, 503) and any(s["last_run"] for s in json.loads(body)["sweeps"].values()):
        if answer(f"{proxy}/accounts/login/")[0] == 200:
            sys.exit(0)
    time.sleep(0.5)
sys.exit(1)
PY
        cat >&2 <<EOF

  hospital_delivery is up: open http://127.0.0.1:${PORT_HTTP}/
  (admin: http://127.0.0.1:${PORT_HTTP}/admin/, API docs: http://127.0.0.1:${PORT_HTTP}/api/docs/,
   everything through nginx on this one port). Requests are logged to var/log/access.log.
  Simulated robots (a share of them VDA 5050 vehicles over MQTT, through the vda5050 bridge)
  drive the site at ${FLEET_SPEEDUP}x real time (a delivery across floors takes
  well under a minute), with ${FLEET_TRAFFIC} random deliveries per simulated hour.
  From here on this terminal shows deliveries, alerts and errors (LOG_LEVEL, default
  WARNING); log times are in ${TZ} (the site's time zone). Ctrl-C stops everything.

${logins}
EOF
    else
        log "the page did not answer at http://127.0.0.1:${PORT_HTTP}/: see the lines above"
    fi
}
mkdir -p var/log
log "starting; the address and the demo logins follow once the page answers"
announce_when_up &
# Prometheus counters of every gunicorn and Celery process go to files here, added up by
# /metrics (prometheus_client's multiprocess mode); a fresh start begins from zero.
export PROMETHEUS_MULTIPROC_DIR="${PROMETHEUS_MULTIPROC_DIR:-${PWD}/var/prometheus}"
rm -rf "${PROMETHEUS_MULTIPROC_DIR}"
mkdir -p "${PROMETHEUS_MULTIPROC_DIR}"
exec "${VENV_DIR}/bin/honcho" start -f Procfile

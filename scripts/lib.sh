# shellcheck shell=bash
# Shared helpers for scripts/run.sh and scripts/test.sh. Source it, don't run it.
#
# Every ensure_* function is idempotent: it checks first, is quiet when all is in place, and
# installs or starts only what is missing (Debian packages with apt, Python packages into .venv).

if [[ -n "${_HD_LIB_SOURCED:-}" ]]; then
    return 0
fi
_HD_LIB_SOURCED=1

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV_DIR="${REPO_ROOT}/.venv"

# How long to wait for a service that was just started before giving up (seconds).
SERVICE_START_TIMEOUT="${SERVICE_START_TIMEOUT:-60}"

# ----------------------------------------------------------------------------------------------
# Output

log() { printf '\033[1;34m==>\033[0m %s\n' "$*" >&2; }
warn() { printf '\033[1;33mwarning:\033[0m %s\n' "$*" >&2; }
die() {
    printf '\033[1;31merror:\033[0m %s\n' "$*" >&2
    exit 1
}

# ----------------------------------------------------------------------------------------------
# Privileges

# as_root CMD...: run CMD as root, through sudo when we are not root.
as_root() {
    if [[ "${EUID}" -eq 0 ]]; then
        "$@"
    elif command -v sudo >/dev/null 2>&1; then
        sudo "$@"
    else
        die "need root for: $* (run as root or install sudo)"
    fi
}

# as_postgres CMD...: run CMD as the postgres system user (peer authentication on the socket).
as_postgres() {
    if [[ "$(id -un)" == postgres ]]; then
        (cd / && "$@")
    elif [[ "${EUID}" -eq 0 ]] && command -v runuser >/dev/null 2>&1; then
        (cd / && runuser -u postgres -- "$@")
    elif [[ "${EUID}" -eq 0 ]]; then
        # su takes one command string; quote every argument for it.
        local quoted
        quoted="$(printf '%q ' "$@")"
        (cd / && su postgres -s /bin/bash -c "${quoted}")
    elif command -v sudo >/dev/null 2>&1; then
        (cd / && sudo -u postgres "$@")
    else
        die "need root or sudo to act as the postgres user"
    fi
}

have_systemd() { [[ -d /run/systemd/system ]] && command -v systemctl >/dev/null 2>&1; }

# start_with_init SERVICE: ask systemd, else the SysV init script, to start SERVICE. Fails when
# there is neither (e.g. a container) or the start command fails.
start_with_init() {
    local name="$1"
    if have_systemd; then
        as_root systemctl start "${name}" && return 0
        warn "systemctl start ${name} failed"
    elif command -v service >/dev/null 2>&1 && [[ -x "/etc/init.d/${name}" ]]; then
        as_root service "${name}" start && return 0
        warn "service ${name} start failed"
    fi
    return 1
}

# ----------------------------------------------------------------------------------------------
# Debian packages

_HD_APT_UPDATED=""

apt_package_installed() {
    [[ "$(dpkg-query -W -f='${Status}' "$1" 2>/dev/null)" == "install ok installed" ]]
}

# ensure_apt_packages PKG...: install the Debian packages that are not installed yet.
ensure_apt_packages() {
    local pkg
    local -a missing=()
    command -v dpkg-query >/dev/null 2>&1 || die "not a Debian system (no dpkg-query); install by hand: $*"
    for pkg in "$@"; do
        apt_package_installed "${pkg}" || missing+=("${pkg}")
    done
    if [[ ${#missing[@]} -eq 0 ]]; then
        return 0
    fi
    log "installing Debian packages: ${missing[*]}"
    if [[ -z "${_HD_APT_UPDATED}" ]]; then
        as_root env DEBIAN_FRONTEND=noninteractive apt-get update -q \
            || die "apt-get update failed"
        _HD_APT_UPDATED=1
    fi
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
        "${missing[@]}" || die "apt-get install failed for: ${missing[*]}"
}

# ----------------------------------------------------------------------------------------------
# Waiting

# wait_until TIMEOUT DESCRIPTION CMD...: poll CMD (quietly) until it succeeds or TIMEOUT seconds
# pass. Returns 1 on timeout without printing; the caller decides what that means.
wait_until() {
    local timeout="$1" what="$2"
    shift 2
    local deadline=$((SECONDS + timeout))
    while ! "$@" >/dev/null 2>&1; do
        if ((SECONDS >= deadline)); then
            return 1
        fi
        sleep 0.25
    done
    [[ -n "${what}" ]] && log "${what} is up"
    return 0
}

# tcp_port_open HOST PORT: something accepts TCP connections there.
tcp_port_open() {
    (exec 3<>"/dev/tcp/$1/$2") 2>/dev/null
}

# ----------------------------------------------------------------------------------------------
# Python virtual environment

# ensure_venv: .venv exists, runs, and has requirements.txt installed. pip runs again only when
# requirements.txt changed since the last successful install (hash stamp inside .venv).
ensure_venv() {
    local req="${REPO_ROOT}/requirements.txt"
    local stamp="${VENV_DIR}/.requirements.sha256"
    local want have=""

    if ! command -v python3 >/dev/null 2>&1; then
        ensure_apt_packages python3
    fi
    python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' \
        || die "Python 3.11 or newer is needed; python3 is $(python3 --version 2>&1)"

    if [[ ! -x "${VENV_DIR}/bin/python" ]] || ! "${VENV_DIR}/bin/python" -c 'import pip' >/dev/null 2>&1; then
        # Debian ships venv's ensurepip separately, in python3-venv.
        if ! python3 -c 'import ensurepip, venv' >/dev/null 2>&1; then
            ensure_apt_packages python3-venv
        fi
        log "creating ${VENV_DIR}"
        python3 -m venv --clear "${VENV_DIR}" || die "could not create ${VENV_DIR}"
    fi

    want="$(sha256sum "${req}" | cut -d' ' -f1)"
    [[ -f "${stamp}" ]] && have="$(cat "${stamp}")"
    if [[ "${want}" != "${have}" ]]; then
        ensure_python_build_deps
        log "installing Python packages from requirements.txt"
        "${VENV_DIR}/bin/python" -m pip install --disable-pip-version-check -q -r "${req}" \
            || die "pip install -r requirements.txt failed"
        printf '%s\n' "${want}" >"${stamp}"
    fi
    export VIRTUAL_ENV="${VENV_DIR}"
    case ":${PATH}:" in
        *":${VENV_DIR}/bin:"*) ;;
        *) export PATH="${VENV_DIR}/bin:${PATH}" ;;
    esac
}

# ensure_python_build_deps: what pip needs to build the packages that ship no wheel for Linux:
# python-ldap (django-auth-ldap's client, hospital sign-in) compiles against Debian's OpenLDAP
# and Cyrus SASL headers, with a C compiler and Python's own headers.
ensure_python_build_deps() {
    ensure_apt_packages libldap2-dev libsasl2-dev gcc libc6-dev
    if ! python3 -c 'import os, sys, sysconfig
sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))'; then
        ensure_apt_packages python3-dev
    fi
}

# ----------------------------------------------------------------------------------------------
# Redis (127.0.0.1:6379)

redis_answers() {
    if command -v redis-cli >/dev/null 2>&1; then
        [[ "$(redis-cli -h 127.0.0.1 -p 6379 ping 2>/dev/null)" == PONG ]]
    else
        # No redis-cli: speak RESP by hand (in a subshell, so a refused connection can't end us).
        (
            exec 3<>/dev/tcp/127.0.0.1/6379 || exit 1
            printf 'PING\r\n' >&3
            reply=""
            read -r -t 2 reply <&3 || exit 1
            [[ "${reply}" == "+PONG"* ]]
        ) 2>/dev/null
    fi
}

ensure_redis() {
    if redis_answers; then
        return 0
    fi
    local fresh=""
    apt_package_installed redis-server || fresh=1
    ensure_apt_packages redis-server
    # apt starts it on a machine with systemd; give that a moment before starting it ourselves.
    if [[ -n "${fresh}" ]] && wait_until 5 "" redis_answers; then
        log "Redis is up"
        return 0
    fi
    log "starting Redis"
    if ! start_with_init redis-server || ! wait_until 10 "" redis_answers; then
        # No init system to ask (e.g. a container): run it ourselves, in memory only.
        redis-server --daemonize yes --bind 127.0.0.1 --port 6379 --save "" --appendonly no \
            --dir "${TMPDIR:-/tmp}" --logfile "${TMPDIR:-/tmp}/hospital_delivery-redis.log" \
            || die "redis-server did not start (see ${TMPDIR:-/tmp}/hospital_delivery-redis.log)"
    fi
    wait_until "${SERVICE_START_TIMEOUT}" "Redis" redis_answers \
        || die "Redis does not answer on 127.0.0.1:6379 after ${SERVICE_START_TIMEOUT}s"
}

# ----------------------------------------------------------------------------------------------
# Mosquitto, the MQTT broker of VDA 5050 vehicles (127.0.0.1:1883)

mosquitto_answers() { tcp_port_open 127.0.0.1 1883; }

ensure_mosquitto() {
    if mosquitto_answers; then
        return 0
    fi
    local fresh=""
    apt_package_installed mosquitto || fresh=1
    ensure_apt_packages mosquitto
    # apt starts it on a machine with systemd; give that a moment before starting it ourselves.
    if [[ -n "${fresh}" ]] && wait_until 5 "" mosquitto_answers; then
        log "Mosquitto is up"
        return 0
    fi
    log "starting Mosquitto"
    if ! start_with_init mosquitto || ! wait_until 10 "" mosquitto_answers; then
        # No init system to ask (e.g. a container): run it ourselves, on loopback only (Debian's
        # default configuration listens on localhost when it names no listener).
        local conf="${TMPDIR:-/tmp}/hospital_delivery-mosquitto.conf"
        printf 'listener 1883 127.0.0.1\nallow_anonymous true\npersistence false\n' >"${conf}"
        mosquitto -d -c "${conf}" \
            || die "mosquitto did not start (config ${conf})"
    fi
    wait_until "${SERVICE_START_TIMEOUT}" "Mosquitto" mosquitto_answers \
        || die "Mosquitto does not answer on 127.0.0.1:1883 after ${SERVICE_START_TIMEOUT}s"
}

# ----------------------------------------------------------------------------------------------
# PostgreSQL (127.0.0.1:5432)

postgres_answers() { pg_isready -q -h 127.0.0.1 -p 5432 -t 2; }

ensure_postgres() {
    if command -v pg_isready >/dev/null 2>&1 && postgres_answers; then
        return 0
    fi
    local fresh=""
    apt_package_installed postgresql || fresh=1
    ensure_apt_packages postgresql
    if [[ -n "${fresh}" ]] && wait_until 5 "" postgres_answers; then
        log "PostgreSQL is up"
        return 0
    fi
    log "starting PostgreSQL"
    if ! start_with_init postgresql || ! wait_until 10 "" postgres_answers; then
        # No init system (e.g. a container): start Debian's "main" cluster(s) directly.
        local conf version
        for conf in /etc/postgresql/*/main; do
            [[ -d "${conf}" ]] || continue
            version="$(basename "$(dirname "${conf}")")"
            as_root pg_ctlcluster --skip-systemctl-redirect "${version}" main start \
                || warn "pg_ctlcluster ${version} main start failed"
        done
    fi
    wait_until "${SERVICE_START_TIMEOUT}" "PostgreSQL" postgres_answers \
        || die "PostgreSQL does not answer on 127.0.0.1:5432 after ${SERVICE_START_TIMEOUT}s"
}

# pg_superuser_psql ARGS...: psql as the postgres superuser. Over TCP when that needs no
# password (trust, as on CI machines), else over the unix socket as the postgres system user
# (peer authentication, the default of a fresh Debian install).
pg_superuser_psql() {
    if PGCONNECT_TIMEOUT=5 psql -w -h 127.0.0.1 -p 5432 -U postgres -d postgres -Atqc 'select 1' \
        >/dev/null 2>&1; then
        psql -w -h 127.0.0.1 -p 5432 -U postgres -d postgres -v ON_ERROR_STOP=1 "$@"
    else
        as_postgres psql -p 5432 -d postgres -v ON_ERROR_STOP=1 "$@"
    fi
}

# ensure_postgres_database ROLE PASSWORD DBNAME: a login role with CREATEDB (pytest-django creates
# and drops test_DBNAME) and a database it owns, reachable over TCP with that password whatever
# the server's authentication method for 127.0.0.1 (trust, md5 or scram-sha-256).
ensure_postgres_database() {
    local role="$1" password="$2" dbname="$3"
    if PGPASSWORD="${password}" PGCONNECT_TIMEOUT=5 psql -w -h 127.0.0.1 -p 5432 -U "${role}" \
        -d "${dbname}" -Atqc 'select 1' >/dev/null 2>&1; then
        return 0
    fi
    log "creating PostgreSQL role ${role} and database ${dbname}"
    pg_superuser_psql -q -v role="${role}" -v password="${password}" -v dbname="${dbname}" \
        >/dev/null <<'SQL' || die "could not create PostgreSQL role ${role} and database ${dbname}"
SELECT format('CREATE ROLE %I LOGIN CREATEDB PASSWORD %L', :'role', :'password')
WHERE NOT EXISTS (SELECT 1 FROM pg_roles WHERE rolname = :'role') \gexec
SELECT format('ALTER ROLE %I LOGIN CREATEDB PASSWORD %L', :'role', :'password') \gexec
SELECT format('CREATE DATABASE %I OWNER %I', :'dbname', :'role')
WHERE NOT EXISTS (SELECT 1 FROM pg_database WHERE datname = :'dbname') \gexec
SQL
    PGPASSWORD="${password}" PGCONNECT_TIMEOUT=5 psql -w -h 127.0.0.1 -p 5432 -U "${role}" \
        -d "${dbname}" -Atqc 'select 1' >/dev/null \
        || die "role ${role} still cannot log in to ${dbname} over 127.0.0.1:5432 (check pg_hba.conf)"
}

# ----------------------------------------------------------------------------------------------
# Chromium (browser tests drive Debian's build through Playwright; never `playwright install`)

CHROMIUM_BIN=/usr/bin/chromium

# ----------------------------------------------------------------------------------------------
# nginx (the proxy in front of gunicorn and daphne; run by honcho with its own configuration,
# not as the system's service)

ensure_nginx() {
    if command -v nginx >/dev/null 2>&1 || [[ -x /usr/sbin/nginx ]]; then
        return 0
    fi
    ensure_apt_packages nginx
    [[ -x /usr/sbin/nginx ]] || die "nginx is missing after installing it"
}

ensure_valgrind() {  # bench/heartbeat_instructions.py counts instructions with callgrind
    command -v valgrind >/dev/null 2>&1 && return 0
    ensure_apt_packages valgrind
    command -v valgrind >/dev/null 2>&1 || die "valgrind is missing after installing it"
}

ensure_chromium() {
    if [[ -x "${CHROMIUM_BIN}" ]]; then
        return 0
    fi
    ensure_apt_packages chromium fonts-liberation
    [[ -x "${CHROMIUM_BIN}" ]] || die "${CHROMIUM_BIN} is missing after installing chromium"
}

# ----------------------------------------------------------------------------------------------
# OpenLDAP's slapd and its tools: the sign-in tests start a directory of their own (a process on a
# free port, its configuration and data in a temporary directory: tests/directory.py). Installing
# the package must not set up or start the system's directory: debconf is told to skip that.

ensure_slapd() {
    if [[ -x /usr/sbin/slapd ]] && command -v slapadd >/dev/null 2>&1 \
        && command -v ldapsearch >/dev/null 2>&1; then
        return 0
    fi
    if ! apt_package_installed slapd; then
        printf 'slapd slapd/no_configuration boolean true\n' | as_root debconf-set-selections \
            || die "debconf-set-selections failed"
    fi
    ensure_apt_packages slapd ldap-utils
    [[ -x /usr/sbin/slapd ]] || die "/usr/sbin/slapd is missing after installing slapd"
}

# ----------------------------------------------------------------------------------------------
# Node.js packages of the test tools (package.json, package-lock.json: exact versions). Node and
# npm come from Debian's packages when missing; `npm ci` runs again only when the lock changed.

ensure_node_packages() {
    local lock="${REPO_ROOT}/package-lock.json"
    local stamp="${REPO_ROOT}/node_modules/.package-lock.sha256"
    local want have=""
    [[ -f "${lock}" ]] || return 0
    if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
        ensure_apt_packages nodejs npm
    fi
    want="$(sha256sum "${lock}" | cut -d' ' -f1)"
    [[ -f "${stamp}" ]] && have="$(cat "${stamp}")"
    if [[ "${want}" != "${have}" ]]; then
        log "installing Node.js packages from package-lock.json"
        (cd "${REPO_ROOT}" && npm ci --no-audit --no-fund --loglevel=error) \
            || die "npm ci failed"
        mkdir -p "${REPO_ROOT}/node_modules"
        printf '%s\n' "${want}" >"${stamp}"
    fi
}

# ----------------------------------------------------------------------------------------------
# The pages' translations: locale/<language>/LC_MESSAGES/django.po are the sources (in git); the
# compiled .mo files Django reads are built from them here, with GNU gettext's msgfmt.

compile_catalogs() {
    command -v msgfmt >/dev/null 2>&1 || ensure_apt_packages gettext
    (cd "${REPO_ROOT}" && python manage.py compilemessages --locale ko --locale it -v 0 \
        --ignore ".venv" --ignore "node_modules" --ignore "var") \
        || die "compiling the translations (locale/) failed"
}

#!/usr/bin/env bash
# THE test command: ./scripts/test.sh [pytest args...]
#
# Installs what it needs (Python packages into .venv; Redis, Mosquitto, PostgreSQL and Chromium
# from Debian's packages when missing), starts Redis, Mosquitto and PostgreSQL when stopped, then runs, stopping
# at the first failure: ruff lint, ruff format check, the import-linter contracts (the layers of
# pyproject.toml), Django's system checks, the missing-migration check, the documentation site's
# build (mkdocs.yml; --strict: a broken link or a page left out of the navigation fails), the
# translations' compilation (locale/) and pytest (which includes
# the bounded property-based runs of tests/security: Hypothesis bodies at the heartbeat and the
# task API, schemathesis over the OpenAPI schema). Extra arguments go to pytest, e.g.
# ./scripts/test.sh -k heartbeat -x
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
# shellcheck source=scripts/lib.sh
source scripts/lib.sh

started=${SECONDS}

ensure_venv
ensure_redis
ensure_mosquitto
ensure_postgres
# A role of the project's own (not the postgres superuser), so no superuser password is touched.
# pytest-django creates and drops test_${TEST_PG_DB}; two runs at once on one machine need
# different names: TEST_PG_DB=hd_alice ./scripts/test.sh
TEST_PG_ROLE=hospital_delivery
TEST_PG_PASSWORD=hospital_delivery
TEST_PG_DB="${TEST_PG_DB:-hospital_delivery}"
ensure_postgres_database "${TEST_PG_ROLE}" "${TEST_PG_PASSWORD}" "${TEST_PG_DB}"
ensure_chromium
ensure_nginx
ensure_valgrind
ensure_slapd  # the sign-in tests run a directory of their own (tests/directory.py)
ensure_node_packages

export SECRET_KEY=test-only-secret
export DATABASE_URL="postgres://${TEST_PG_ROLE}:${TEST_PG_PASSWORD}@127.0.0.1:5432/${TEST_PG_DB}"
# Database 15 of the local Redis belongs to the tests; run.sh uses database 0.
export REDIS_URL=redis://127.0.0.1:6379/15
# Test servers run in threads and subprocesses; pooled connections would outlive each test.
export DATABASE_CONN_MAX_AGE=0
# Browser tests launch Debian's Chromium (executable_path); Playwright must never download one.
export CHROMIUM_PATH="${CHROMIUM_BIN}"
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1
export PYTHONDONTWRITEBYTECODE=1
# Material for MkDocs prints a notice about MkDocs 2 on every build; the build's own warnings stay.
export NO_MKDOCS_2_WARNING=1

step() {
    local name="$1"
    shift
    printf '\n\033[1;36m======== %s\033[0m\n' "${name}" >&2
    printf '\033[2m$ %s\033[0m\n' "$*" >&2
    local rc=0
    "$@" || rc=$?
    if [[ ${rc} -ne 0 ]]; then
        printf '\n\033[1;31m======== FAILED: %s (exit %d) after %ds\033[0m\n' \
            "${name}" "${rc}" "$((SECONDS - started))" >&2
        exit "${rc}"
    fi
}

step "ruff lint" ruff check .
step "ruff format" ruff format --check .
step "import layers" lint-imports --no-cache
step "django system checks" python manage.py check
step "missing migrations" python manage.py makemigrations --check --dry-run
step "documentation" mkdocs build --strict
step "translations" compile_catalogs
# Two workers: the target machines have two cores; each worker gets its own test database.
# worksteal: a worker that runs out of tests takes some of the other's, so a few long tests
# left at the end of one worker's share do not keep the other idle.
step "pytest" pytest -n "${PYTEST_WORKERS:-2}" --dist worksteal "$@"

printf '\n\033[1;32m======== all passed in %ds\033[0m\n' "$((SECONDS - started))" >&2

#!/usr/bin/env bash
# Starts a throwaway PostgreSQL server for the tests, on loopback only, in a temporary
# directory, and stops it again.
#   pg-test-server.sh start [DIR]   prints postgresql://postgres@127.0.0.1:PORT/postgres
#                                   (also written to DIR/url); DIR defaults to a new temp dir
#   pg-test-server.sh stop DIR      stops the server and removes DIR
# When the PostgreSQL binaries are absent, `start` prints a reason on stderr, writes no
# url file and exits 0 so that the tests that need the server skip with that reason.
# PG_BIN overrides where initdb/pg_ctl are looked for.
set -euo pipefail

find_bin() {
  local d
  for d in "${PG_BIN:-}" /usr/lib/postgresql/*/bin /usr/local/pgsql/bin; do
    [ -n "$d" ] && [ -x "$d/initdb" ] && [ -x "$d/pg_ctl" ] && { echo "$d"; return 0; }
  done
  command -v initdb >/dev/null 2>&1 && command -v pg_ctl >/dev/null 2>&1 &&
    { dirname "$(command -v initdb)"; return 0; }
  return 1
}

# initdb and postgres refuse to run as root: run them as the postgres user then.
as_owner() {
  if [ "$(id -u)" -eq 0 ]; then runuser -u postgres -- "$@"; else "$@"; fi
}

cmd=${1:-}
case "$cmd" in
start)
  dir=${2:-}
  if ! bin=$(find_bin); then
    echo "pg-test-server: PostgreSQL binaries (initdb, pg_ctl) not found; install Debian's postgresql" >&2
    [ -n "$dir" ] && mkdir -p "$dir" && echo "PostgreSQL binaries not found" >"$dir/unavailable"
    exit 0
  fi
  if [ "$(id -u)" -eq 0 ] && ! id postgres >/dev/null 2>&1; then
    echo "pg-test-server: running as root but there is no postgres user" >&2
    [ -n "$dir" ] && mkdir -p "$dir" && echo "no postgres user to run the server as" >"$dir/unavailable"
    exit 0
  fi
  [ -n "$dir" ] || dir=$(mktemp -d /tmp/ld-pg.XXXXXX)
  if [ -d "$dir/data" ]; then  # left over from an interrupted run
    as_owner "$bin/pg_ctl" -D "$dir/data" -m immediate -w stop >/dev/null 2>&1 || true
    rm -rf "$dir/data"
  fi
  mkdir -p "$dir"
  rm -f "$dir/url" "$dir/unavailable"
  [ "$(id -u)" -eq 0 ] && chown postgres "$dir"
  chmod 700 "$dir"
  as_owner "$bin/initdb" -D "$dir/data" -U postgres --auth=trust -E UTF8 --no-locale --no-sync >"$dir/initdb.log" 2>&1 ||
    { cat "$dir/initdb.log" >&2; exit 1; }
  # A free port: try random ones until the server starts (another one may take it meanwhile).
  for _ in 1 2 3 4 5 6 7 8; do
    port=$((20000 + RANDOM % 30000))
    if as_owner "$bin/pg_ctl" -D "$dir/data" -l "$dir/server.log" -w -t 30 start \
      -o "-p $port -k $dir -c listen_addresses=127.0.0.1 -c fsync=off -c synchronous_commit=off -c full_page_writes=off -c max_connections=60" \
      >/dev/null 2>&1; then
      url="postgresql://postgres@127.0.0.1:$port/postgres"
      echo "$url" >"$dir/url"
      echo "$url"
      exit 0
    fi
  done
  echo "pg-test-server: could not start the server; see $dir/server.log" >&2
  tail -n 20 "$dir/server.log" >&2 || true
  exit 1
  ;;
stop)
  dir=${2:?usage: pg-test-server.sh stop DIR}
  if [ -d "$dir/data" ] && bin=$(find_bin); then
    as_owner "$bin/pg_ctl" -D "$dir/data" -m immediate -w stop >/dev/null 2>&1 || true
  fi
  rm -rf "$dir"
  ;;
*)
  echo "usage: pg-test-server.sh start [DIR] | stop DIR" >&2
  exit 2
  ;;
esac

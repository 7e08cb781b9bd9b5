#!/usr/bin/env bash
# A throwaway PostgreSQL server for the tests that need a real database
# (tests/design/test_design_postgres.py).
#
#   source .ci/postgres.sh && pg_tmp_start DIR    # installs Debian's postgresql if absent, starts a
#                                                 # server in DIR (loopback + a socket in DIR only),
#                                                 # creates user + database, exports SPINE_GYM_TEST_PG_URL
#   pg_tmp_stop DIR                               # stops it (the data dir stays in DIR; delete DIR after)
#
# The server runs as the `postgres` system user (initdb refuses root), listens on 127.0.0.1 on a free
# port and on a Unix socket inside DIR, and accepts only password (scram-sha-256) logins on TCP.
# Every step fails loudly: callers run with `set -e`.

PG_TMP_USER=spine
PG_TMP_PASSWORD=spine-ci-pw
PG_TMP_DB=spine_design

# as the postgres user, from a directory it can enter (the caller's may be root-only)
pg_tmp_as_postgres() {
  (cd / && runuser -u postgres -- "$@")
}

pg_tmp_bindir() {
  ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -n 1
}

pg_tmp_install() {
  if [ -z "$(pg_tmp_bindir)" ] || ! id postgres >/dev/null 2>&1; then
    echo "postgres: installing Debian's postgresql"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q >/dev/null
    apt-get install -y -q --no-install-recommends postgresql >/dev/null
  fi
  [ -n "$(pg_tmp_bindir)" ] || { echo "postgres: no server binaries after install" >&2; return 1; }
}

pg_tmp_free_port() {
  python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

pg_tmp_start() {
  local dir=$1 bin port
  pg_tmp_install
  bin=$(pg_tmp_bindir)
  mkdir -p "$dir"
  chown postgres: "$dir"
  chmod 700 "$dir"
  port=$(pg_tmp_free_port)
  pg_tmp_as_postgres "$bin/initdb" -D "$dir/data" -U postgres --auth-local=trust \
    --auth-host=scram-sha-256 -E UTF8 >"$dir/initdb.log"
  pg_tmp_as_postgres "$bin/pg_ctl" -D "$dir/data" -l "$dir/server.log" -w -t 60 \
    -o "-c listen_addresses=127.0.0.1 -c port=$port -c unix_socket_directories=$dir -c fsync=off" start \
    >/dev/null
  pg_tmp_as_postgres "$bin/psql" -h "$dir" -p "$port" -U postgres -d postgres -v ON_ERROR_STOP=1 -q \
    -c "CREATE ROLE $PG_TMP_USER LOGIN PASSWORD '$PG_TMP_PASSWORD'" \
    -c "CREATE DATABASE $PG_TMP_DB OWNER $PG_TMP_USER"
  export SPINE_GYM_TEST_PG_URL="postgresql+psycopg2://$PG_TMP_USER:$PG_TMP_PASSWORD@127.0.0.1:$port/$PG_TMP_DB"
  echo "postgres: server $("$bin/postgres" --version | awk '{print $3}') on 127.0.0.1:$port (data in $dir)"
}

pg_tmp_stop() {
  local dir=$1 bin
  bin=$(pg_tmp_bindir)
  if [ -n "$bin" ] && [ -f "$dir/data/postmaster.pid" ]; then
    pg_tmp_as_postgres "$bin/pg_ctl" -D "$dir/data" -m fast -w stop >/dev/null
    echo "postgres: server stopped"
  fi
}

"""The nginx in front of the servers (scripts/run.sh; `manage.py proxy_config` writes it).

One origin for everything: pages, the API and robots' heartbeats go to gunicorn, websockets
(`/ws/`: pages' live events and robots' push channel) to daphne, `/static/` is served by nginx
itself. nginx reads a request's whole body before passing it on, so a client sending one byte
at a time ties up an nginx connection, not one of gunicorn's few sync workers (gunicorn's own
documentation asks for such a buffering proxy in front of sync workers).

Each request carries the client's address to Django: nginx appends the address it received it
from to X-Forwarded-For (and sets X-Real-IP to it), and Django trusts that many entries from
the right as settings.TRUSTED_PROXY_COUNT says (1 for this proxy; core/clientaddress.py), so a
client's own X-Forwarded-For entries, to the left, count for nothing.

Heartbeats that a push-channel wake caused (header `Woken-By`, docs/robot-protocol.md) go to
gunicorn's second socket (`web_woken`), which it binds first: each free worker takes a
connection waiting there before the next regular one, so a woken robot is answered within
milliseconds however long the queue of regular heartbeats (bench/heartbeat.py's push columns).
"""

from dataclasses import dataclass
from pathlib import Path

# Bodies nginx takes: a heartbeat is at most 64 KiB (protocol); pages and the API post less
# than this, and the app refuses what it must with its own error shape first.
CLIENT_MAX_BODY = "3m"
# Each robot's heartbeat takes two connections while it is proxied (the robot's and gunicorn's)
# and each push channel two for as long as it is open, pages' sockets the same: nginx's default
# of 1,024 runs out with a thousand robots heartbeating ("worker_connections are not enough",
# connections reset). The open files nginx may hold follow.
WORKER_CONNECTIONS = 16384


@dataclass(frozen=True)
class Upstreams:
    listen: str  # host:port the proxy listens on, e.g. 127.0.0.1:8000
    web: str  # gunicorn, e.g. 127.0.0.1:8002
    web_woken: str  # gunicorn's socket for woken heartbeats, e.g. 127.0.0.1:8003
    ws: str  # daphne, e.g. 127.0.0.1:8001
    static_root: Path  # the collected static files (settings.STATIC_ROOT)
    runtime: Path  # nginx's pid file and temporary bodies
    user: str | None = None  # the workers' user when nginx starts as root


def nginx_config(upstreams: Upstreams) -> str:
    runtime = upstreams.runtime
    user = f"user {upstreams.user};\n" if upstreams.user else ""
    return f"""# Written by `manage.py proxy_config` (hospital_delivery/proxy.py): do not edit.
{user}worker_processes 1;
worker_rlimit_nofile {2 * WORKER_CONNECTIONS};
pid {runtime}/nginx.pid;
error_log stderr warn;

events {{
    worker_connections {WORKER_CONNECTIONS};
}}

http {{
    include /etc/nginx/mime.types;
    default_type application/octet-stream;
    access_log off;  # gunicorn logs the requests it serves
    sendfile on;
    server_tokens off;
    client_max_body_size {CLIENT_MAX_BODY};
    client_body_timeout 20s;  # a client that stalls mid-body is dropped, not waited for
    client_body_temp_path {runtime}/body;
    proxy_temp_path {runtime}/proxy;
    fastcgi_temp_path {runtime}/fastcgi;
    uwsgi_temp_path {runtime}/uwsgi;
    scgi_temp_path {runtime}/scgi;

    map $http_upgrade $connection_upgrade {{
        default upgrade;
        ''      close;
    }}

    map $http_woken_by $web_lane {{
        default web_woken;
        ''      web;
    }}

    upstream web {{ server {upstreams.web}; keepalive 16; }}
    upstream web_woken {{ server {upstreams.web_woken}; keepalive 4; }}
    upstream ws {{ server {upstreams.ws}; }}

    server {{
        listen {upstreams.listen};

        location /static/ {{
            alias {upstreams.static_root}/;
            expires 1h;
        }}

        location /ws/ {{
            proxy_pass http://ws;
            proxy_http_version 1.1;
            proxy_set_header Upgrade $http_upgrade;
            proxy_set_header Connection $connection_upgrade;
            proxy_set_header Host $http_host;
            proxy_set_header X-Forwarded-For $proxy_add_x_forwarded_for;
            proxy_set_header X-Real-IP $remote_addr;
            proxy_read_timeout 1h;  # pages and robots keep their sockets open
        }}

        location / {{
            proxy_pass http://$web_lane;
            proxy_http_version 1.1;
            proxy_set_header Connection "";
            proxy_set_header Host $http_host;
            proxy_set_header X-Forwarded-For $proxy_add_x_forwarded_for;
            proxy_set_header X-Real-IP $remote_addr;
            # When the request was passed on: the heartbeat's wait for a worker (core/overload.py).
            proxy_set_header X-Request-Start "t=$msec";
            proxy_request_buffering on;  # the whole body first: slow clients never reach gunicorn
            proxy_buffering on;
        }}
    }}
}}
"""

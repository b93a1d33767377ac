"""A real OpenID Connect provider for the sign-in tests: the npm package oidc-provider (pinned in
package.json, installed by scripts/lib.sh ensure_node_packages) run by node from
tests/oidc_provider.mjs on a free port, with one client (the server under test) and accounts
whose groups it puts in the `groups` claim."""

import json
import subprocess
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

from tests import servers

CLIENT_ID, CLIENT_SECRET = "hospital-delivery", "client-secret-for-tests"
PASSWORD = "Provider-pw-1"  # every test account's


@dataclass
class Account:
    sub: str
    username: str
    given_name: str
    family_name: str
    groups: list[str] = field(default_factory=list)
    password: str = PASSWORD

    @property
    def email(self) -> str:
        return f"{self.username}@hospital.test"


class Provider:
    def __init__(self, accounts: list[Account], *, server_urls: list[str]):
        """server_urls: where the servers under test answer (their callback and login URLs are
        registered with the provider, as an administrator registers them)."""
        self.port = servers.free_port()
        self.issuer = f"http://127.0.0.1:{self.port}"
        self.accounts, self.server_urls = accounts, server_urls
        self.process = None
        self._dir = tempfile.TemporaryDirectory(prefix="hd-oidc-")

    def settings(self) -> dict:
        return {
            "OIDC_ISSUER": self.issuer,
            "OIDC_RP_CLIENT_ID": CLIENT_ID,
            "OIDC_RP_CLIENT_SECRET": CLIENT_SECRET,
            "OIDC_RP_SCOPES": "openid email profile groups",
            "OIDC_PROVIDER_NAME": "Test ID",
        }

    def env(self) -> dict:
        return {
            "OIDC_ISSUER": self.issuer,
            "OIDC_CLIENT_ID": CLIENT_ID,
            "OIDC_CLIENT_SECRET": CLIENT_SECRET,
            "OIDC_SCOPES": "openid email profile groups",
            "OIDC_PROVIDER_NAME": "Test ID",
        }

    def start(self) -> None:
        client = {
            "client_id": CLIENT_ID,
            "client_secret": CLIENT_SECRET,
            "redirect_uris": [f"{url}/oidc/callback/" for url in self.server_urls],
            "post_logout_redirect_uris": [f"{url}/accounts/login/" for url in self.server_urls],
            "token_endpoint_auth_method": "client_secret_post",
        }
        accounts = [{**asdict(account), "email": account.email} for account in self.accounts]
        config = Path(self._dir.name) / "provider.json"
        config.write_text(
            json.dumps({"port": self.port, "clients": [client], "accounts": accounts})
        )
        command = ["node", str(servers.REPO / "tests" / "oidc_provider.mjs"), str(config)]
        self.process = subprocess.Popen(command, cwd=servers.REPO, stdout=subprocess.DEVNULL)
        servers.wait_for_port(self.port, self.process)

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            self.process.wait(timeout=15)
        self._dir.cleanup()

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.stop()

"""A real LDAP directory for the sign-in tests: Debian's OpenLDAP slapd (scripts/lib.sh,
ensure_slapd) started on a free port with its configuration and data in a temporary directory,
never the system's slapd. Its people, groups for each role and for two sites, a read-only
service account as Active Directory deployments use, and the password policy overlay, with
which an administrator disables an account (pwdAccountLockedTime) so that it cannot bind.

It can serve StartTLS with a certificate made for it (`tls=True`), its CA in `ca_file`.
"""

import datetime
import ipaddress
import os
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import ldap
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

from tests import servers

SUFFIX = "dc=hospital,dc=test"
ADMIN_DN, ADMIN_PASSWORD = f"cn=admin,{SUFFIX}", "directory-admin-secret"
READER_DN, READER_PASSWORD = f"cn=hd-reader,ou=services,{SUFFIX}", "reader-secret"
PEOPLE, GROUPS = f"ou=people,{SUFFIX}", f"ou=groups,{SUFFIX}"
PASSWORD = "Directory-pw-1"  # every test person's
# ppolicy's value for "locked by an administrator until unlocked" (slapo-ppolicy(5)).
LOCKED_FOR_GOOD = b"000001010000Z"


def person_dn(uid: str) -> str:
    return f"uid={uid},{PEOPLE}"


def group_dn(name: str) -> str:
    return f"cn={name},{GROUPS}"


@dataclass
class Person:
    uid: str
    given_name: str
    surname: str
    groups: list[str] = field(default_factory=list)


SLAPD_CONF = """\
include /etc/ldap/schema/core.schema
include /etc/ldap/schema/cosine.schema
include /etc/ldap/schema/inetorgperson.schema
include /etc/ldap/schema/nis.schema
modulepath /usr/lib/ldap
moduleload back_mdb
moduleload ppolicy
pidfile {root}/slapd.pid
{tls}
database mdb
suffix "{suffix}"
rootdn "{admin_dn}"
rootpw {admin_password}
directory {root}/data
overlay ppolicy
ppolicy_default "cn=default,ou=policies,{suffix}"
access to attrs=userPassword by anonymous auth by self write by * none
access to * by users read by * none
"""


class Directory:
    def __init__(self, people: list[Person], *, tls: bool = False):
        self.people, self.tls = people, tls
        self.port = servers.free_port()
        self.url = f"ldap://127.0.0.1:{self.port}"
        self._root = tempfile.TemporaryDirectory(prefix="hd-slapd-")
        self.root = Path(self._root.name)
        self.ca_file = str(self.root / "ca.pem")
        self.process = None

    def settings(self) -> dict:
        """The Django settings of a server that signs in against this directory (the
        environment variables of the same names and the settings module make the same)."""
        from django_auth_ldap.config import GroupOfNamesType, LDAPSearch

        options = {
            ldap.OPT_REFERRALS: 0,
            ldap.OPT_NETWORK_TIMEOUT: 5,
            ldap.OPT_TIMEOUT: 5,
            ldap.OPT_X_TLS_REQUIRE_CERT: ldap.OPT_X_TLS_DEMAND,
            **({ldap.OPT_X_TLS_CACERTFILE: self.ca_file} if self.tls else {}),
            ldap.OPT_X_TLS_NEWCTX: 0,
        }
        return {
            "AUTH_LDAP_SERVER_URI": self.url,
            "AUTH_LDAP_BIND_DN": READER_DN,
            "AUTH_LDAP_BIND_PASSWORD": READER_PASSWORD,
            "AUTH_LDAP_START_TLS": self.tls,
            "AUTH_LDAP_USER_SEARCH": LDAPSearch(PEOPLE, ldap.SCOPE_SUBTREE, "(uid=%(user)s)"),
            "AUTH_LDAP_GROUP_SEARCH": LDAPSearch(GROUPS, ldap.SCOPE_SUBTREE, "(objectClass=*)"),
            "AUTH_LDAP_GROUP_TYPE": GroupOfNamesType(),
            "AUTH_LDAP_CONNECTION_OPTIONS": options,
        }

    def env(self) -> dict:
        """The same, as the environment of a server process."""
        env = {
            "AUTH_LDAP_SERVER_URI": self.url,
            "AUTH_LDAP_BIND_DN": READER_DN,
            "AUTH_LDAP_BIND_PASSWORD": READER_PASSWORD,
            "AUTH_LDAP_USER_SEARCH_BASE": PEOPLE,
            "AUTH_LDAP_GROUP_SEARCH_BASE": GROUPS,
        }
        if self.tls:
            env.update({"AUTH_LDAP_START_TLS": "true", "AUTH_LDAP_CA_FILE": self.ca_file})
        return env

    # --- Running -----------------------------------------------------------------------------

    def start(self) -> None:
        (self.root / "data").mkdir()
        tls = self._certificates() if self.tls else ""
        conf = self.root / "slapd.conf"
        conf.write_text(
            SLAPD_CONF.format(
                root=self.root,
                tls=tls,
                suffix=SUFFIX,
                admin_dn=ADMIN_DN,
                admin_password=ADMIN_PASSWORD,
            )
        )
        data = self.root / "data.ldif"
        data.write_text(self._ldif())
        subprocess.run(
            ["slapadd", "-q", "-f", str(conf), "-l", str(data)],
            check=True,
            capture_output=True,
        )
        # -d: in the foreground (no daemon to find later), logging nothing (0).
        command = ["/usr/sbin/slapd", "-f", str(conf), "-h", f"{self.url}/", "-d", "0"]
        self.process = subprocess.Popen(command, stderr=subprocess.DEVNULL)
        servers.wait_for_port(self.port, self.process)

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            self.process.wait(timeout=15)
        self._root.cleanup()

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.stop()

    # --- What an administrator does in the directory ------------------------------------------

    def _admin(self):
        connection = ldap.initialize(self.url)
        if self.tls:
            connection.set_option(ldap.OPT_X_TLS_CACERTFILE, self.ca_file)
            connection.set_option(ldap.OPT_X_TLS_NEWCTX, 0)
            connection.start_tls_s()
        connection.simple_bind_s(ADMIN_DN, ADMIN_PASSWORD)
        return connection

    def _modify(self, dn: str, changes: list) -> None:
        connection = self._admin()
        try:
            connection.modify_s(dn, changes)
        finally:
            connection.unbind_s()

    def group_remove(self, group: str, uid: str) -> None:
        self._modify(group_dn(group), [(ldap.MOD_DELETE, "member", [person_dn(uid).encode()])])

    def group_add(self, group: str, uid: str) -> None:
        self._modify(group_dn(group), [(ldap.MOD_ADD, "member", [person_dn(uid).encode()])])

    def disable(self, uid: str) -> None:
        locked = [(ldap.MOD_REPLACE, "pwdAccountLockedTime", [LOCKED_FOR_GOOD])]
        self._modify(person_dn(uid), locked)

    # --- Its contents -------------------------------------------------------------------------

    def _ldif(self) -> str:
        entries = [
            f"dn: {SUFFIX}\nobjectClass: dcObject\nobjectClass: organization\ndc: hospital\n"
            "o: Test hospital",
            *(
                f"dn: ou={ou},{SUFFIX}\nobjectClass: organizationalUnit\nou: {ou}"
                for ou in ("people", "groups", "services", "policies")
            ),
            f"dn: cn=default,ou=policies,{SUFFIX}\nobjectClass: device\n"
            "objectClass: pwdPolicy\ncn: default\npwdAttribute: userPassword\npwdLockout: TRUE",
            f"dn: {READER_DN}\nobjectClass: organizationalRole\nobjectClass: simpleSecurityObject\n"
            f"cn: hd-reader\nuserPassword: {READER_PASSWORD}",
        ]
        members: dict[str, list[str]] = {}
        for person in self.people:
            entries.append(
                f"dn: {person_dn(person.uid)}\nobjectClass: inetOrgPerson\nuid: {person.uid}\n"
                f"cn: {person.given_name} {person.surname}\ngivenName: {person.given_name}\n"
                f"sn: {person.surname}\nmail: {person.uid}@hospital.test\n"
                f"userPassword: {PASSWORD}"
            )
            for group in person.groups:
                members.setdefault(group, []).append(person_dn(person.uid))
        for group, dns in members.items():
            lines = "".join(f"\nmember: {dn}" for dn in dns)
            entries.append(f"dn: {group_dn(group)}\nobjectClass: groupOfNames\ncn: {group}{lines}")
        return "\n\n".join(entries) + "\n"

    def _certificates(self) -> str:
        """A CA and a certificate for 127.0.0.1 that it signed; the slapd.conf lines."""
        now = datetime.datetime.now(datetime.UTC)
        ca_key = ec.generate_private_key(ec.SECP256R1())
        key = ec.generate_private_key(ec.SECP256R1())
        ca_name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "Test hospital CA")])
        ca = (
            x509.CertificateBuilder()
            .subject_name(ca_name)
            .issuer_name(ca_name)
            .public_key(ca_key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=1))
            .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
            .sign(ca_key, hashes.SHA256())
        )
        name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "127.0.0.1")])
        certificate = (
            x509.CertificateBuilder()
            .subject_name(name)
            .issuer_name(ca_name)
            .public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=1))
            .add_extension(
                x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]),
                critical=False,
            )
            .sign(ca_key, hashes.SHA256())
        )
        pem = serialization.Encoding.PEM
        Path(self.ca_file).write_bytes(ca.public_bytes(pem))
        (self.root / "cert.pem").write_bytes(certificate.public_bytes(pem))
        key_file = self.root / "key.pem"
        key_file.write_bytes(
            key.private_bytes(pem, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
        )
        os.chmod(key_file, 0o600)
        return (
            f"TLSCACertificateFile {self.ca_file}\nTLSCertificateFile {self.root}/cert.pem\n"
            f"TLSCertificateKeyFile {key_file}"
        )

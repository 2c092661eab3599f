#!/usr/bin/python3
"""GET a URL and print the status code on the first line, then the body (for tests that ask a
web endpoint from inside a network namespace, where only a command can run). Redirects are not
followed: a test sees the answer itself (303 from /login). An https URL is checked against the CA
certificate in $PLEXUS_CA_FILE (else the system's), as a browser that trusts that CA would; or,
with $PLEXUS_CERT_SHA256 (AB:CD:...), its certificate must have that fingerprint, as a person
compares a self-signed certificate's with what `plexus web` printed before accepting it.

    http_get.py URL [HEADER: VALUE]...
"""
import hashlib
import http.client
import os
import ssl
import sys
import urllib.error
import urllib.request



class NoRedirects(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args, **kwargs):
        return None


handlers = [NoRedirects]
if os.environ.get('PLEXUS_CA_FILE'):
    handlers.append(urllib.request.HTTPSHandler(
        context=ssl.create_default_context(cafile=os.environ['PLEXUS_CA_FILE'])))
elif os.environ.get('PLEXUS_CERT_SHA256'):
    expected = os.environ['PLEXUS_CERT_SHA256'].replace(':', '').lower()
    pinned = ssl.create_default_context()
    pinned.check_hostname = False
    pinned.verify_mode = ssl.CERT_NONE  # checked below, by its fingerprint

    class PinnedConnection(http.client.HTTPSConnection):
        def connect(self):
            super().connect()
            seen = hashlib.sha256(self.sock.getpeercert(binary_form=True)).hexdigest()
            if seen != expected:
                self.sock.close()
                raise ssl.SSLError(f'certificate fingerprint {seen} is not the expected {expected}')

    class PinnedHandler(urllib.request.HTTPSHandler):
        def https_open(self, request):
            return self.do_open(PinnedConnection, request, context=pinned)

    handlers.append(PinnedHandler())
opener = urllib.request.build_opener(*handlers)
request = urllib.request.Request(sys.argv[1])
for header in sys.argv[2:]:
    name, value = header.split(':', 1)
    request.add_header(name.strip(), value.strip())
try:
    with opener.open(request, timeout=20) as reply:
        status, body = reply.status, reply.read()
except urllib.error.HTTPError as refused:
    status, body = refused.code, refused.read()
sys.stdout.write(f'{status}\n')
sys.stdout.write(body.decode('utf-8', 'replace'))

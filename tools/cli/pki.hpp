#pragma once
// `plexus pki`: a deployment's certificate authority, on files (docs/SECURITY.md, "Identities").
// A CA directory holds the CA's key and certificate, the revocation list, and what was issued:
//   ca.key       the CA's private key (ECDSA P-256, mode 600): whoever holds it makes identities
//   ca.crt       the CA's certificate, which every identity trusts
//   crl.pem      the certificates revoked, signed by the CA
//   issued.json  the serial number of each certificate issued, and those revoked
//   nodes/NAME/  an identity per node, names/NAME/ per name server (proto/identity.hpp): copied to
//                its machine, given to plexusd or plexus-names with --identity
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/identity.hpp"

namespace plexus::cli {

/// Makes a new CA in `directory` (made, mode 700); refused where a CA is already.
proto::Status pki_init(const std::string& directory, int days);

/// Issues an identity for `subject` from the CA in `ca`: a new key, a certificate naming it,
/// with the CA's certificate and revocation list beside them, in `out` (empty: the CA's
/// nodes/NAME or names/NAME). `web_hosts`: the addresses or host names a browser reaches the
/// node's web endpoint by (its HTTPS certificate must name them). Refused while the subject holds
/// a certificate not revoked. Returns the identity's directory.
proto::Result<std::string> pki_issue(const std::string& ca, const proto::Subject& subject, std::string out,
                                     int days, const std::vector<std::string>& web_hosts = {});

/// What the CA in `ca` issued: one entry per certificate, oldest first, with "subject"
/// (plexus:node:NAME or plexus:names:NAME), "serial", "identity" (where it was written) and
/// "revoked". An Error when there is no CA there.
proto::Result<nlohmann::json> pki_list(const std::string& ca);

/// Revokes the certificate of `subject`: a new revocation list in the CA, copied into every
/// identity under it. Daemons and name servers read it again before their next handshake.
/// Returns the serial number revoked.
proto::Result<std::uint64_t> pki_revoke(const std::string& ca, const proto::Subject& subject);

}  // namespace plexus::cli

// `plexus pki init|issue|revoke`: the deployment's certificate authority (pki.hpp).
#include <cstdlib>
#include <iostream>

#include "command_line.hpp"
#include "number_checks.hpp"
#include "pki.hpp"

namespace plexus::cli {

namespace {
/// The CA directory: --ca (init: DIR), else $PLEXUS_CA, else ./plexus-ca: here, beside the
/// command's other outputs (as `plexus record` writes here), so that `plexus pki init` and
/// `plexus pki issue NODE` work as they are (DESIGN.md).
std::string ca_directory(const std::string& flag) {
    if (!flag.empty())
        return flag;
    const char* env = std::getenv("PLEXUS_CA");
    if (env && *env)
        return env;
    return "plexus-ca";
}

proto::Subject subject_of(const PkiOptions& options) {
    return {options.names ? proto::Subject::Kind::names : proto::Subject::Kind::node, options.name};
}
}  // namespace

void CommandLine::add_pki_commands() {
    auto& pki = pki_options_;
    auto* pki_cmd = app_.add_subcommand(
        "pki",
        "the deployment's certificate authority: identities for nodes and name servers, so that each "
        "can act only as the one its certificate names, and revocation (docs/SECURITY.md)");
    pki_cmd->require_subcommand(1);

    auto* init_cmd = pki_cmd->add_subcommand(
        "init",
        "make a new CA in DIR (mode 700): its key ca.key (mode 600; keep it off the robots), its "
        "certificate ca.crt, an empty revocation list crl.pem");
    init_cmd->add_option("DIR", pki.ca, "the CA's directory, made (default: $PLEXUS_CA, else ./plexus-ca)");
    init_cmd->add_option("--days", pki.days, "how long the CA's certificate is valid")
        ->transform(whole_number(1, 36500))
        ->capture_default_str();
    init_cmd->callback([this, &pki] {
        const std::string ca = ca_directory(pki.ca);
        if (auto made = pki_init(ca, pki.days); !made)
            throw plexus::Error(ErrorCode::refused, made.error().message);
        std::cout << "CA made in " << ca << "; issue identities with `plexus pki issue NODE --ca " << ca
                  << "`\n";
        status_ = 0;
    });

    auto* issue_cmd = pki_cmd->add_subcommand(
        "issue",
        "issue NAME's identity: a new key (mode 600) and a certificate naming it, with the CA's "
        "certificate and revocation list, in the CA's nodes/NAME (names/NAME with --names) or "
        "--out; give the directory to plexusd --identity (plexus-names --identity)");
    issue_cmd->add_option("NAME", pki.name, "the node's name (its --node), or the name server's")->required();
    issue_cmd->add_option("--ca", pki.ca, "the CA's directory (default: $PLEXUS_CA, else ./plexus-ca)");
    issue_cmd->add_flag("--names", pki.names, "a name server's identity, not a node's");
    issue_cmd->add_option("--out", pki.out, "where to put the identity (made, mode 700)");
    issue_cmd->add_option("--web", pki.web,
                          "an address or host name browsers reach the node's web endpoint by (repeatable): "
                          "plexusd --http beyond loopback then serves HTTPS with this certificate");
    issue_cmd->add_option("--days", pki.days, "how long the certificate is valid")
        ->transform(whole_number(1, 36500))
        ->capture_default_str();
    issue_cmd->callback([this, &pki] {
        auto issued = pki_issue(ca_directory(pki.ca), subject_of(pki), pki.out, pki.days, pki.web);
        if (!issued)
            throw plexus::Error(ErrorCode::refused, issued.error().message);
        std::cout << subject_of(pki).text() << ": identity in " << *issued << "\n";
        status_ = 0;
    });

    auto* list_cmd = pki_cmd->add_subcommand(
        "list",
        "what the CA issued: each certificate's subject, serial number, whether it is revoked, "
        "and where its identity was written");
    list_cmd->add_option("--ca", pki.ca, "the CA's directory (default: $PLEXUS_CA, else ./plexus-ca)");
    list_cmd->add_flag("--json", pki.json, "print JSON");
    list_cmd->callback([this, &pki] {
        auto listed = pki_list(ca_directory(pki.ca));
        if (!listed)
            throw plexus::Error(ErrorCode::refused, listed.error().message);
        if (pki.json) {
            std::cout << listed->dump() << '\n';
        } else {
            for (const auto& entry : *listed) {
                const auto subject = proto::Subject::from_uri(entry.value("subject", std::string()));
                std::cout << (subject ? subject->text() : entry.value("subject", std::string("?")))
                          << "  serial " << entry.value("serial", std::uint64_t{0})
                          << (entry.value("revoked", false) ? "  REVOKED" : "  valid") << "  "
                          << entry.value("identity", std::string()) << '\n';
            }
        }
        status_ = 0;
    });

    auto* revoke_cmd = pki_cmd->add_subcommand(
        "revoke",
        "revoke NAME's certificate: a new crl.pem in the CA and in every identity still under it "
        "(copy it to the other machines); daemons and name servers refuse the certificate from "
        "their next handshake on");
    revoke_cmd->add_option("NAME", pki.name, "the node's name, or the name server's")->required();
    revoke_cmd->add_option("--ca", pki.ca, "the CA's directory (default: $PLEXUS_CA, else ./plexus-ca)");
    revoke_cmd->add_flag("--names", pki.names, "a name server's identity, not a node's");
    revoke_cmd->callback([this, &pki] {
        auto revoked = pki_revoke(ca_directory(pki.ca), subject_of(pki));
        if (!revoked)
            throw plexus::Error(ErrorCode::refused, revoked.error().message);
        std::cout << subject_of(pki).text() << ": certificate " << *revoked << " revoked; copy "
                  << ca_directory(pki.ca) << "/crl.pem to the identities on other machines\n";
        status_ = 0;
    });
}

}  // namespace plexus::cli

#include "pki.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>

#include <nlohmann/json.hpp>

#include "plexus/proto/certificates.hpp"
#include "plexus/proto/pem_files.hpp"
#include "plexus/proto/tls_psk.hpp"

namespace plexus::cli {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using proto::CrlPtr;
using proto::FilePtr;
using proto::KeyPtr;
using proto::X509Ptr;
using TimePtr = std::unique_ptr<ASN1_TIME, proto::OpenSslFree<ASN1_TIME, ::ASN1_TIME_free>>;

/// A CA's files.
struct CaFiles {
    fs::path directory;
    fs::path key() const { return directory / "ca.key"; }
    fs::path certificate() const { return directory / "ca.crt"; }
    fs::path crl() const { return directory / "crl.pem"; }
    fs::path issued() const { return directory / "issued.json"; }
    fs::path identity_of(const proto::Subject& subject) const {
        return directory / (subject.kind == proto::Subject::Kind::names ? "names" : "nodes") / subject.name;
    }
};

proto::Error failed(const std::string& what) {
    return proto::Error{what + ": " + proto::last_tls_error()};
}

/// Writes a private key that only its owner may read, from the moment the file exists.
bool write_private_key(const fs::path& path, EVP_PKEY* key) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0)
        return false;
    ::fchmod(fd, 0600);  // an existing file keeps its mode through O_CREAT
    FILE* file = ::fdopen(fd, "w");
    if (!file) {
        ::close(fd);
        return false;
    }
    const bool written = ::PEM_write_PrivateKey(file, key, nullptr, nullptr, 0, nullptr, nullptr) == 1;
    return std::fclose(file) == 0 && written;
}

/// Writes a public file whole, by a rename: a daemon reading it (the revocation list) never
/// sees half of one.
template <class Write>
bool write_public(const fs::path& path, Write write) {
    const fs::path next = path.string() + ".new";
    {
        FilePtr file(std::fopen(next.c_str(), "w"), std::fclose);
        if (!file || !write(file.get()))
            return false;
    }
    ::chmod(next.c_str(), 0644);
    std::error_code error;
    fs::rename(next, path, error);
    return !error;
}

json read_issued(const CaFiles& ca) {
    std::ifstream in(ca.issued());
    json issued = json::parse(in, nullptr, false);
    if (issued.is_discarded() || !issued.is_object())
        return json{{"next_serial", 2}, {"certificates", json::array()}};
    return issued;
}

bool write_issued(const CaFiles& ca, const json& issued) {
    return write_public(ca.issued(), [&](FILE* file) {
        const std::string text = issued.dump(2) + "\n";
        return std::fwrite(text.data(), 1, text.size(), file) == text.size();
    });
}

/// The revocation list of every certificate `issued` marks revoked, signed by the CA, valid ten
/// years (a list past its next update makes every handshake fail).
proto::Status write_crl(const CaFiles& ca, const json& issued, X509* ca_certificate, EVP_PKEY* ca_key) {
    CrlPtr crl(::X509_CRL_new());
    const std::time_t now = std::time(nullptr);
    TimePtr this_update(::ASN1_TIME_adj(nullptr, now, 0, 0));
    TimePtr next_update(::ASN1_TIME_adj(nullptr, now, 3650, 0));
    if (!crl || !this_update || !next_update || ::X509_CRL_set_version(crl.get(), X509_CRL_VERSION_2) != 1 ||
        ::X509_CRL_set_issuer_name(crl.get(), ::X509_get_subject_name(ca_certificate)) != 1 ||
        ::X509_CRL_set1_lastUpdate(crl.get(), this_update.get()) != 1 ||
        ::X509_CRL_set1_nextUpdate(crl.get(), next_update.get()) != 1)
        return failed("cannot make the revocation list");
    for (const auto& entry : issued["certificates"]) {
        if (!entry.value("revoked", false))
            continue;
        X509_REVOKED* revoked = ::X509_REVOKED_new();
        ASN1_INTEGER* serial = ::ASN1_INTEGER_new();
        const bool set = revoked && serial &&
                         ::ASN1_INTEGER_set_uint64(serial, entry["serial"].get<std::uint64_t>()) == 1 &&
                         ::X509_REVOKED_set_serialNumber(revoked, serial) == 1 &&
                         ::X509_REVOKED_set_revocationDate(revoked, this_update.get()) == 1;
        ::ASN1_INTEGER_free(serial);
        if (!set || ::X509_CRL_add0_revoked(crl.get(), revoked) != 1) {
            ::X509_REVOKED_free(revoked);
            return failed("cannot list a revoked certificate");
        }
    }
    ::X509_CRL_sort(crl.get());
    if (::X509_CRL_sign(crl.get(), ca_key, ::EVP_sha256()) <= 0)
        return failed("cannot sign the revocation list");
    if (!write_public(ca.crl(), [&](FILE* file) { return ::PEM_write_X509_CRL(file, crl.get()) == 1; }))
        return proto::Error{"cannot write " + ca.crl().string()};
    return proto::Ok{};
}

struct LoadedCa {
    KeyPtr key;
    X509Ptr certificate;
};

proto::Result<LoadedCa> load_ca(const CaFiles& ca) {
    LoadedCa loaded{proto::read_private_key(ca.key()), proto::read_certificate(ca.certificate())};
    if (!loaded.key || !loaded.certificate)
        return proto::Error{"no CA in " + ca.directory.string() +
                            " (ca.key and ca.crt; `plexus pki init DIR` makes one)"};
    return loaded;
}

bool is_address(const std::string& host) {
    unsigned char bytes[16];
    return ::inet_pton(AF_INET, host.c_str(), bytes) == 1 || ::inet_pton(AF_INET6, host.c_str(), bytes) == 1;
}

bool good_name(const std::string& name) {
    if (name.empty() || name.size() > 64)
        return false;
    for (const char c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.')
            return false;
    }
    return name != "." && name != "..";
}

}  // namespace

proto::Status pki_init(const std::string& directory, int days) {
    const CaFiles ca{directory};
    std::error_code error;
    if (fs::exists(ca.key(), error))
        return proto::Error{"there is a CA in " + directory +
                            " already (ca.key): its identities would no longer be "
                            "trusted; choose another directory"};
    fs::create_directories(ca.directory, error);
    if (error)
        return proto::Error{"cannot make " + directory + ": " + error.message()};
    ::chmod(directory.c_str(), 0700);
    KeyPtr key(proto::new_key());
    if (!key)
        return failed("cannot make the CA's key");
    auto certificate = proto::make_certificate(1, "Plexus deployment CA", key.get(), nullptr, key.get(), days,
                                               {{NID_basic_constraints, "critical,CA:TRUE,pathlen:0"},
                                                {NID_key_usage, "critical,keyCertSign,cRLSign"},
                                                {NID_subject_key_identifier, "hash"}});
    if (!certificate)
        return failed("cannot make the CA's certificate");
    if (!write_private_key(ca.key(), key.get()))
        return proto::Error{"cannot write " + ca.key().string()};
    if (!write_public(ca.certificate(),
                      [&](FILE* file) { return ::PEM_write_X509(file, certificate.get()) == 1; }))
        return proto::Error{"cannot write " + ca.certificate().string()};
    const json issued{{"next_serial", 2}, {"certificates", json::array()}};
    if (!write_issued(ca, issued))
        return proto::Error{"cannot write " + ca.issued().string()};
    return write_crl(ca, issued, certificate.get(), key.get());
}

proto::Result<std::string> pki_issue(const std::string& ca_directory, const proto::Subject& subject,
                                     std::string out, int days, const std::vector<std::string>& web_hosts) {
    const CaFiles ca{ca_directory};
    if (!good_name(subject.name))
        return proto::Error{"'" + subject.name +
                            "' cannot name an identity: 1 to 64 letters, digits, '-', '_' or '.'"};
    auto loaded = load_ca(ca);
    if (!loaded)
        return loaded.error();
    json issued = read_issued(ca);
    for (const auto& entry : issued["certificates"]) {
        if (entry["subject"] == subject.uri() && !entry.value("revoked", false))
            return proto::Error{subject.text() + " has a certificate already (serial " +
                                entry["serial"].dump() +
                                "); revoke it first (`plexus pki revoke`) to issue a new one"};
    }
    // The subject's URI, then the names a browser checks: an address as IP, anything else as DNS.
    std::string alt_names = "URI:" + subject.uri();
    for (const auto& host : web_hosts) {
        if (host.empty() || (host.find_first_of(",:\n") != std::string::npos && !is_address(host)))
            return proto::Error{"--web '" + host + "': a host name or an IP address"};
        alt_names += (is_address(host) ? ",IP:" : ",DNS:") + host;
    }
    const std::uint64_t serial = issued["next_serial"].get<std::uint64_t>();
    KeyPtr key(proto::new_key());
    if (!key)
        return failed("cannot make the key");
    auto certificate = proto::make_certificate(serial, subject.name, key.get(), loaded->certificate.get(),
                                               loaded->key.get(), days,
                                               {{NID_basic_constraints, "critical,CA:FALSE"},
                                                {NID_key_usage, "critical,digitalSignature"},
                                                {NID_ext_key_usage, "serverAuth,clientAuth"},
                                                {NID_subject_alt_name, alt_names},
                                                {NID_subject_key_identifier, "hash"},
                                                {NID_authority_key_identifier, "keyid:always"}});
    if (!certificate)
        return failed("cannot make the certificate of " + subject.text());
    const fs::path identity = out.empty() ? ca.identity_of(subject) : fs::path(out);
    std::error_code error;
    fs::create_directories(identity, error);
    if (error)
        return proto::Error{"cannot make " + identity.string() + ": " + error.message()};
    ::chmod(identity.c_str(), 0700);
    if (!write_private_key(identity / "node.key", key.get()))
        return proto::Error{"cannot write " + (identity / "node.key").string()};
    if (!write_public(identity / "node.crt",
                      [&](FILE* file) { return ::PEM_write_X509(file, certificate.get()) == 1; }))
        return proto::Error{"cannot write " + (identity / "node.crt").string()};
    fs::copy_file(ca.certificate(), identity / "ca.crt", fs::copy_options::overwrite_existing, error);
    if (!error)
        fs::copy_file(ca.crl(), identity / "crl.pem", fs::copy_options::overwrite_existing, error);
    if (error)
        return proto::Error{"cannot copy the CA's files into " + identity.string() + ": " + error.message()};
    issued["certificates"].push_back(
        {{"subject", subject.uri()}, {"serial", serial}, {"identity", fs::absolute(identity).string()}});
    issued["next_serial"] = serial + 1;
    if (!write_issued(ca, issued))
        return proto::Error{"cannot write " + ca.issued().string()};
    return identity.string();
}

proto::Result<json> pki_list(const std::string& ca_directory) {
    const CaFiles ca{ca_directory};
    if (auto loaded = load_ca(ca); !loaded)
        return loaded.error();
    json certificates = read_issued(ca)["certificates"];
    for (auto& entry : certificates)
        entry["revoked"] = entry.value("revoked", false);
    return certificates;
}

proto::Result<std::uint64_t> pki_revoke(const std::string& ca_directory, const proto::Subject& subject) {
    const CaFiles ca{ca_directory};
    auto loaded = load_ca(ca);
    if (!loaded)
        return loaded.error();
    json issued = read_issued(ca);
    std::optional<std::uint64_t> serial;
    for (auto& entry : issued["certificates"]) {
        if (entry["subject"] == subject.uri() && !entry.value("revoked", false)) {
            entry["revoked"] = true;
            serial = entry["serial"].get<std::uint64_t>();
        }
    }
    if (!serial)
        return proto::Error{subject.text() + " holds no certificate of this CA that is not revoked already"};
    if (!write_issued(ca, issued))
        return proto::Error{"cannot write " + ca.issued().string()};
    if (auto written = write_crl(ca, issued, loaded->certificate.get(), loaded->key.get()); !written)
        return written.error();
    // Every identity this CA issued that is still where it was made gets the new list; those
    // copied to other machines need it copied too (docs/SECURITY.md).
    for (const auto& entry : issued["certificates"]) {
        const fs::path identity = entry.value("identity", std::string());
        std::error_code error;
        if (!identity.empty() && fs::exists(identity / "crl.pem", error)) {
            const bool copied = write_public(identity / "crl.pem", [&](FILE* to) {
                std::ifstream in(ca.crl(), std::ios::binary);
                const std::string text((std::istreambuf_iterator<char>(in)),
                                       std::istreambuf_iterator<char>());
                return std::fwrite(text.data(), 1, text.size(), to) == text.size();
            });
            if (!copied)
                return proto::Error{"cannot write " + (identity / "crl.pem").string()};
        }
    }
    return *serial;
}

}  // namespace plexus::cli

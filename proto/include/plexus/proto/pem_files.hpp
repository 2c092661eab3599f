#pragma once
// OpenSSL's objects owned by unique_ptr, and the PEM files of a deployment's CA and identities
// read into them (proto/identity.hpp, tools/cli/pki.cpp). A file that is missing or not the PEM
// asked for reads as null; OpenSSL's error queue says why.

#include <openssl/pem.h>
#include <openssl/x509.h>

#include <cstdio>
#include <memory>
#include <string>

namespace plexus::proto {

template <class T, void (*Free)(T*)>
struct OpenSslFree {
    void operator()(T* p) const { Free(p); }
};
using KeyPtr = std::unique_ptr<EVP_PKEY, OpenSslFree<EVP_PKEY, ::EVP_PKEY_free>>;
using X509Ptr = std::unique_ptr<X509, OpenSslFree<X509, ::X509_free>>;
using CrlPtr = std::unique_ptr<X509_CRL, OpenSslFree<X509_CRL, ::X509_CRL_free>>;
using FilePtr = std::unique_ptr<FILE, int (*)(FILE*)>;

/// Reads the first object of `read`'s kind from the PEM file at `path`.
template <class Owned, class Read>
Owned read_pem(const std::string& path, Read read) {
    FilePtr file(std::fopen(path.c_str(), "r"), std::fclose);
    return Owned(file ? read(file.get(), nullptr, nullptr, nullptr) : nullptr);
}

inline X509Ptr read_certificate(const std::string& path) {
    return read_pem<X509Ptr>(path, ::PEM_read_X509);
}
inline KeyPtr read_private_key(const std::string& path) {
    return read_pem<KeyPtr>(path, ::PEM_read_PrivateKey);
}
inline CrlPtr read_crl(const std::string& path) {
    return read_pem<CrlPtr>(path, ::PEM_read_X509_CRL);
}

}  // namespace plexus::proto

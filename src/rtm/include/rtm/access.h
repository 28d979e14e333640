// SPDX-License-Identifier: Apache-2.0
// Access control: by default only the user who started a system may change it.
//
// Each user has a random access key in a file only they can read (access_key_path():
// $RTM_KEY_FILE, else ~/.rtm/key, made on first use, mode 0600 in a 0700 folder). Every GIOP
// request an RTM process sends carries its user's key in a service context; a component
// refuses a change (on, off, reset, set_parameter, subscribe, unsubscribe, put and its
// variants) that does not carry its own user's key with CORBA::NO_PERMISSION, before the
// request's arguments are read. Reading (get, state, statistics, ports, describe, ...) stays
// open to every local user. Calls inside one process take omniORB's local shortcut and are not
// checked.
//
// A client that knows only the 2004 IDL (idl/RTM.idl) sends no key: the owner lets such
// clients change a component by starting it with --access open (AccessPolicy::open).
//
// Across hosts the credential is a certificate instead (rtm/tls.h): a request that arrives
// over a giop:ssl: connection whose peer presented a certificate of this process's authority
// may change it without the key.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rtm {

enum class AccessPolicy : std::uint8_t {
  owner,  // changes need the key of the user who started the process (the default)
  open,   // anyone who can reach the endpoints may change it (2004 clients)
};
// "owner" or "open"; nullopt otherwise.
std::optional<AccessPolicy> parse_access_policy(std::string_view text);

using AccessKey = std::array<unsigned char, 32>;

// Where this user's key lives: $RTM_KEY_FILE, else $HOME/.rtm/key.
std::string access_key_path();
// Reads the key, making it (random, 0600, folder 0700) when the file does not exist. Throws
// std::runtime_error naming the file and the reason when it cannot be read or made, or when
// it is not this user's or others may read it.
AccessKey load_or_make_access_key();

// Sets what this process's requests carry and what its servants require, before rtm::Orb is
// made: every request carries `key` (none: nothing is sent, and changes elsewhere are refused);
// changes to this process's servants need `key` unless `policy` is open.
void configure_access(const std::optional<AccessKey>& key, AccessPolicy policy);
// What rtm::Orb does unless the process configured its own: this user's key when it can be
// read or made (else none: this process can read components but change none), policy owner.
void configure_default_access();
// rtm::Orb, right after ORB_init (omniORB has no interceptors before it): adds the two
// interceptors, once per process.
void register_access_interceptors();

// Whether operation `name` (a GIOP operation name) changes a component or its ports.
bool is_change_operation(std::string_view name);

// The same interceptor screens every put before its argument is read: a datum whose type is
// no data type (an any holding an any, whose unmarshalling omniORB 4.2 does in time doubling
// per level; an object reference, a value, a TypeCode) is refused with CORBA::BAD_PARAM
// (minor kNotPlainDataMinor), whatever the access policy. Refusals of either kind are logged
// (the first three, then every thousandth).
inline constexpr std::uint32_t kNotPlainDataMinor = 0x52544d02;  // "RTM" 2

// The minor code of the NO_PERMISSION a refused change raises.
inline constexpr std::uint32_t kAccessRefusedMinor = 0x52544d01;  // "RTM" 1

}  // namespace rtm

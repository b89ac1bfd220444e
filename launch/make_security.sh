#!/usr/bin/env bash
# DDS Security for a hullpipe lab (docs/architecture.md): makes a lab CA, one identity per
# name given, the signed governance and permissions documents, and a Cyclone
# configuration per identity that only lets the lab's nodes join (Cyclone's
# authentication, access control and cryptography plugins, Debian package
# libddsc0debian).
#   launch/make_security.sh OUT_DIR [IFACE] [NAME...]     (default: lo, "node")
# Writes OUT_DIR/ca.pem (+ key), OUT_DIR/<name>.pem (+ key), governance.p7s,
# permissions.p7s and cyclonedds-secure-<name>.xml. Give every node of the lab
# one of the configs (CYCLONEDDS_URI=file://... or --dds-config). A participant
# without a certificate from this CA is not authenticated: it sees nothing and
# nothing it publishes is accepted (tests/security_test.cc).
# Governance: join access control on, RTPS messages signed, every topic's
# read/write access controlled; data is not encrypted (maps and images are
# large; set data_protection_kind to ENCRYPT where the network is not trusted).
# The CA key in OUT_DIR signs everything: keep it off the lab's machines.
set -euo pipefail
OUT="$1"; IFACE="${2:-lo}"; shift || true; shift || true
NAMES=("$@"); [ ${#NAMES[@]} -eq 0 ] && NAMES=(node)
mkdir -p "$OUT"; cd "$OUT"
PLUGINS=$(dirname "$(ls /usr/lib/*/libddsc0debian/libdds_security_auth.so | head -1)")
ORG="hullpipe lab"
openssl ecparam -name prime256v1 -genkey -noout -out ca_key.pem
openssl req -x509 -new -key ca_key.pem -out ca.pem -days 3650 -subj "/C=NL/O=$ORG/CN=$ORG CA" 2>/dev/null
cat > governance.xml <<GOV
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>230</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>NONE</discovery_protection_kind>
      <liveliness_protection_kind>NONE</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>false</enable_discovery_protection>
          <enable_liveliness_protection>false</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>NONE</metadata_protection_kind>
          <data_protection_kind>NONE</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
GOV
{
  echo '<?xml version="1.0" encoding="UTF-8"?>'
  echo '<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">'
  echo '  <permissions>'
  for n in "${NAMES[@]}"; do
    cat <<GRANT
    <grant name="$n">
      <subject_name>C=NL,O=$ORG,CN=$n</subject_name>
      <validity><not_before>2020-01-01T00:00:00</not_before><not_after>2040-01-01T00:00:00</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>230</max></id_range></domains>
        <publish><topics><topic>*</topic></topics></publish>
        <subscribe><topics><topic>*</topic></topics></subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
GRANT
  done
  echo '  </permissions>'
  echo '</dds>'
} > permissions.xml
openssl smime -sign -in governance.xml -text -out governance.p7s -signer ca.pem -inkey ca_key.pem
openssl smime -sign -in permissions.xml -text -out permissions.p7s -signer ca.pem -inkey ca_key.pem
for n in "${NAMES[@]}"; do
  openssl ecparam -name prime256v1 -genkey -noout -out "${n}_key.pem"
  openssl req -new -key "${n}_key.pem" -out "$n.csr" -subj "/C=NL/O=$ORG/CN=$n" 2>/dev/null
  openssl x509 -req -in "$n.csr" -CA ca.pem -CAkey ca_key.pem -CAcreateserial -out "$n.pem" -days 3650 2>/dev/null
  D="$PWD"
  cat > "cyclonedds-secure-$n.xml" <<CFG
<?xml version="1.0" encoding="UTF-8"?>
<!-- Written by launch/make_security.sh: DDS Security for identity "$n". -->
<CycloneDDS xmlns="https://cdds.io/config">
  <Domain id="any">
    <General>
      <Interfaces><NetworkInterface name="$IFACE"/></Interfaces>
      <AllowMulticast>false</AllowMulticast>
      <MaxMessageSize>65500B</MaxMessageSize>
    </General>
    <Discovery>
      <ParticipantIndex>auto</ParticipantIndex>
      <MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>
      <Peers><Peer address="127.0.0.1"/></Peers>
      <SPDPInterval>1s</SPDPInterval>
    </Discovery>
    <Security>
      <Authentication>
        <Library path="$PLUGINS/libdds_security_auth.so" initFunction="init_authentication" finalizeFunction="finalize_authentication"/>
        <IdentityCA>file:$D/ca.pem</IdentityCA>
        <IdentityCertificate>file:$D/$n.pem</IdentityCertificate>
        <PrivateKey>file:$D/${n}_key.pem</PrivateKey>
      </Authentication>
      <AccessControl>
        <Library path="$PLUGINS/libdds_security_ac.so" initFunction="init_access_control" finalizeFunction="finalize_access_control"/>
        <PermissionsCA>file:$D/ca.pem</PermissionsCA>
        <Governance>file:$D/governance.p7s</Governance>
        <Permissions>file:$D/permissions.p7s</Permissions>
      </AccessControl>
      <Cryptographic>
        <Library path="$PLUGINS/libdds_security_crypto.so" initFunction="init_crypto" finalizeFunction="finalize_crypto"/>
      </Cryptographic>
    </Security>
  </Domain>
</CycloneDDS>
CFG
done
echo "wrote $OUT: ca.pem, governance.p7s, permissions.p7s, ${NAMES[*]/%/.pem}, cyclonedds-secure-*.xml"

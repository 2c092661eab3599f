#pragma once
// The carrier grammar `plexus connect --help` prints, from DESIGN.md's "Carrier strings",
// "Arbitration by stimulation" and "Monitors, second pass": the string a newcomer must write is
// described where they type it.

namespace plexus::cli {

inline constexpr const char* carrier_help = R"(CARRIER: a base carrier, then parts joined by '+'.
Base carriers:
  tcp     reliable, ordered
  udp     best effort; losses are counted (plexus stats)
  mcast   one send to many readers
  local   same daemon, in-process; chosen by itself when both ends live on the same
          daemon, unless the carrier names another
Clauses: send.NAME runs in the sending daemon, before the network; recv.NAME runs in the
receiving daemon. The key.value parts after a clause belong to it until the next send./recv.;
several clauses on one side form a chain, applied in order.
key.value is split at the FIRST dot only, so values may hold dots (tc.0.5, file.a.b). A key
without a value is a flag (aux). Lists use commas; name:weight pairs use a colon.
Quote the whole carrier for the shell when it holds spaces or parentheses.
Parts:
  portmonitor  a monitor: type.lua + file.NAME (NAME.lua from plexusd --scripts DIR), or
               type.so + file.NAME (from plexusd --monitor-libs DIR); constraint.EXPR
               (event names with and, or, not, parentheses, true, false); aux (never
               delivered, only regulates the others); onerror.drop|pass. Other keys are
               handed to the script's create(options), as strings.
  priority     arbitration by stimulation, real numbers [defaults]: tc decay time in seconds
               [1.0], tr resting time [0 = no resting], st stimulation per message [1.0],
               bs bias [1.0], ex weights to other connections into the same port, by their
               source port: ex./face/out:-1,/obj/out:0.5 [none]; aux.
  qos.dscp.N   mark the connection's packets with DSCP N (0-63)
  qos.prio.N   serve this connection's queue before lower ones (0-7, higher first)
Examples:
  tcp
  udp
  tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.8
  tcp+send.portmonitor+type.lua+file.codec+recv.portmonitor+type.lua+file.codec
  'tcp+recv.portmonitor+constraint.e_template_ok and not e_particle_ok'
  tcp+recv.priority+tc.0.5+st.1+bs.1+ex./face/out:-1
A carrier with an unknown part, a missing script or a constraint that does not parse makes
connect fail with a message naming the part; nothing is half-connected.)";

}  // namespace plexus::cli

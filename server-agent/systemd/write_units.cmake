# Writes the agent's two systemd units from one template (splitvk-agent.service.in), so that the
# service and the template unit per GPU are confined alike: run by `cmake --install` (see
# server-agent/CMakeLists.txt) with SPLITVK_AGENT_PATH, SPLITVK_UNIT_TEMPLATE and SPLITVK_UNIT_OUTPUT_DIR set.

# splitvk-agent.service: one agent on GPU 0, loopback until a drop-in says otherwise.
set(SPLITVK_UNIT_HEADER "# splitvk-agent as a systemd service: docs/security.md, \"Running the agent as a service\".
# Installed by `cmake --install`. Change what you need with a drop-in (`systemctl edit
# splitvk-agent`), not here: the listen address and the token, as docs/security.md shows.")
set(SPLITVK_UNIT_DESCRIPTION "splitvk agent: replays split-rendered Vulkan sessions on this machine's GPU")
set(SPLITVK_UNIT_AFTER "")
set(SPLITVK_UNIT_EXEC "# Loopback only until a drop-in says otherwise (a LAN address also needs --token-file).
ExecStart=${SPLITVK_AGENT_PATH} --listen 127.0.0.1:7447")
set(SPLITVK_UNIT_STATE "splitvk-agent")
set(SPLITVK_UNIT_INSTALL "")
configure_file("${SPLITVK_UNIT_TEMPLATE}" "${SPLITVK_UNIT_OUTPUT_DIR}/splitvk-agent.service" @ONLY)

# splitvk-agent@.service: one agent per GPU, the instance its index or UUID (--list-devices), each
# advertised over DNS-SD: docs/user-guide.md, "Running a venue".
set(SPLITVK_UNIT_HEADER "# splitvk-agent@GPU.service: one agent per GPU of this machine, GPU being the index or the UUID
# `splitvk-agent --list-devices` prints (`systemctl enable --now splitvk-agent@0 splitvk-agent@1`).
# Each instance advertises itself over DNS-SD (_splitvk._tcp) through avahi-daemon, with its GPU and
# free session slots. Installed by `cmake --install`; docs/user-guide.md, \"Running a venue\", and
# docs/security.md. Settings go into /etc/splitvk/agent-GPU.env (AGENT_LISTEN, AGENT_ARGS), or a
# drop-in (`systemctl edit splitvk-agent@0`), not here.")
set(SPLITVK_UNIT_DESCRIPTION "splitvk agent on GPU %i, advertised over DNS-SD")
set(SPLITVK_UNIT_AFTER "# Advertising needs avahi-daemon; the agent serves without it, and advertises once it starts.
Wants=avahi-daemon.service
After=avahi-daemon.service")
set(SPLITVK_UNIT_EXEC "# Loopback on a port of the kernel's choice (DNS-SD carries the port) until
# /etc/splitvk/agent-%i.env sets AGENT_LISTEN=0.0.0.0:PORT and AGENT_ARGS=--token-file ... (a LAN
# address needs a token).
Environment=AGENT_LISTEN=127.0.0.1:0
Environment=AGENT_ARGS=
EnvironmentFile=-/etc/splitvk/agent-%i.env
ExecStart=${SPLITVK_AGENT_PATH} --listen \${AGENT_LISTEN} --device %i --advertise $AGENT_ARGS")
# Each GPU's agent has its own identity unless AGENT_ARGS names a shared --tls-cert and --tls-key
# (a pool behind one address: docs/security.md).
set(SPLITVK_UNIT_STATE "splitvk-agent/%i")
set(SPLITVK_UNIT_INSTALL "DefaultInstance=0")
configure_file("${SPLITVK_UNIT_TEMPLATE}" "${SPLITVK_UNIT_OUTPUT_DIR}/splitvk-agent@.service" @ONLY)

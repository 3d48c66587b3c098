# The broker of compose.yaml: Debian's mosquitto (no image registry needed beyond the base image).
FROM debian:bookworm-slim
RUN apt-get update -qq \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends mosquitto mosquitto-clients \
 && apt-get clean && rm -rf /var/lib/apt/lists/*
USER mosquitto
# Without a config file mosquitto 2 listens on loopback only and allows anonymous clients: right for
# host networking on one machine. Give a config (listener, password_file, acl_file) for a shared broker.
CMD ["mosquitto", "-p", "1883"]

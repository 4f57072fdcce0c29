"""What every node uses: runtime and executors, parameters, diagnostics, QoS profiles,
message conversion and introspection, message info (lost messages, command ownership)."""

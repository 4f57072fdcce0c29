"""``hexctl topic|node|param|service|action|interface``: the ros2cli verbs a user of this
package needs, on a wheel-only ROS 2 install (ros2cli is not on PyPI). One module a verb;
the shared plumbing (a short-lived node, waiting for discovery to settle, QoS options, YAML
arguments, exit codes) in :mod:`.common`.
"""

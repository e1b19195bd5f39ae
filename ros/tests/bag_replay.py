#!/usr/bin/python3
"""Replays a bag recorded from an autoscan_node run into another node (docs/ros.md, issue 46).

bag_replay.py BAG [TIMEOUT_S]

The bag holds the robot's side of the run: /tf, /input/points (or the depth topics), /refused_view,
and the node's /status. Inputs are published in the recorded order; after each scan the replay waits
until the new node counts it (or refuses it), as the robot did; where the recorded node answered a
compute_next_views (status event "views" or "done"), the new node is asked too. Exit 0 when every
recorded input was taken and every plan asked for; 1 otherwise."""
import json
import sys
import threading

import rosbag
import rospy
from std_msgs.msg import String
from std_srvs.srv import Trigger

bag_path = sys.argv[1]
timeout = float(sys.argv[2]) if len(sys.argv) > 2 else 120.0
rospy.init_node("autoscan_bag_replay", anonymous=True)

status = {}
status_cv = threading.Condition()


def on_status(m):
    with status_cv:
        status.clear()
        status.update(json.loads(m.data))
        status_cv.notify_all()


rospy.Subscriber("status", String, on_status, queue_size=50)


def wait(pred, what):
    with status_cv:
        if not status_cv.wait_for(lambda: pred(status), timeout):
            sys.exit(f"bag_replay: timed out waiting for {what} (status {status})")


wait(lambda s: "scans" in s, "the node's status")
publishers = {}
compute = rospy.ServiceProxy("compute_next_views", Trigger)
scans = inputs = plans = 0
input_topics = {"/input/points", "/input/depth/image_rect", "/input/depth/camera_info", "/tf", "/refused_view"}
with rosbag.Bag(bag_path) as bag:
    topics = bag.get_type_and_topic_info().topics
    for topic in input_topics & set(topics):
        cls = next(m for _, m, _ in bag.read_messages(topics=[topic])).__class__
        latch = topic == "/input/depth/camera_info"
        publishers[topic] = rospy.Publisher(topic, cls, queue_size=100, latch=latch)
    rospy.sleep(1.0)  # connections
    for topic, msg, _ in bag.read_messages(topics=sorted(input_topics | {"/status"})):
        if topic == "/status":
            event = json.loads(msg.data).get("event")
            if event in ("views", "done"):
                rospy.wait_for_service("compute_next_views", timeout)
                answer = compute()
                if not answer.success:
                    sys.exit(f"bag_replay: compute_next_views failed: {answer.message}")
                plans += 1
            continue
        if topic == "/refused_view":
            before = status.get("refused_views", 0)
            publishers[topic].publish(msg)
            wait(lambda s: s.get("refused_views", 0) > before, "the refused view")
            inputs += 1
            continue
        publishers[topic].publish(msg)
        if topic in ("/input/points", "/input/depth/image_rect"):
            refused = status.get("refused_inputs", 0)
            wait(lambda s: s.get("scans", 0) > scans or s.get("refused_inputs", 0) > refused, f"scan {scans}")
            if status.get("scans", 0) <= scans:
                sys.exit(f"bag_replay: the node refused scan {scans}: {status.get('error')}")
            scans += 1
            inputs += 1
print(f"bag_replay: {scans} scans, {inputs} inputs, {plans} plans replayed")

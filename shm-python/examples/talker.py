"""Publish camera frames: 640x480 RGB images, ten a second.

    python talker.py [count]
"""

import sys
import time

import numpy as np
import shm_cdr

count = int(sys.argv[1]) if len(sys.argv) > 1 else None
node = shm_cdr.Node("talker")
publisher = node.create_publisher("sensor_msgs/msg/Image", "camera/image")
Image = shm_cdr.message_type("sensor_msgs/msg/Image")

frame = np.zeros((480, 640, 3), dtype=np.uint8)
seq = 0
while count is None or seq < count:
    frame[:] = seq % 256
    image = Image(height=480, width=640, encoding="rgb8", step=640 * 3, data=frame.ravel())
    image.header.frame_id = "camera"
    image.header.stamp.sec = seq
    went = publisher.publish(image)  # "shm": written into shared memory
    print(f"sent frame {seq} ({went})", flush=True)
    seq += 1
    time.sleep(0.1)

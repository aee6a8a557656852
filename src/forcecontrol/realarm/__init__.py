"""What a real arm needs: F/T calibration, recorded data (CSV, Parquet, ROS 2 bags, MCAP), vendor
conventions, replay of recordings through a controller, traces against simulation, the real-time loop.
"""

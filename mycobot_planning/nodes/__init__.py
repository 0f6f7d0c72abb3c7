"""Thin rclpy nodes: they translate parameters, topics and requests into core library calls."""

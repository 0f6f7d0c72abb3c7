"""mycobot_planning.ros.dedicated_service: a service answered on threads of its own (move_group's
services are), on the ROS graph as any other, up to ``threads`` requests at once, one client's
requests on one thread, never behind the node's executor, surviving a handler that raises, work
left for after the response (after_response), and gone after close()."""
from __future__ import annotations

import threading
import time
from collections import Counter
from typing import Any

import pytest
from std_msgs.msg import String
from std_srvs.srv import SetBool

from mycobot_planning.ros.dedicated_service import DedicatedService, after_response
from ros_testing import ProbeNode, use_session_domain, wait_until

NAME = "/dedicated_test/set"


@pytest.fixture
def pair():
    """A server node spun on a single-threaded executor, and a client node."""
    use_session_domain()
    server, client = ProbeNode("dedicated_server"), ProbeNode("dedicated_client")
    server.spin_in_background()
    client.spin_in_background()
    try:
        yield server, client
    finally:
        client.close()
        server.close()


def _call_async(client: ProbeNode, data: bool) -> Any:
    service = client.client(SetBool, NAME)
    assert service.wait_for_service(timeout_sec=15.0)
    return service.call_async(SetBool.Request(data=data))


def test_requests_are_answered_and_the_service_is_on_the_graph_but_not_on_the_executor(pair):
    server, client = pair

    def handler(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        response.success = request.data
        response.message = threading.current_thread().name
        return response

    service = DedicatedService(server.node, SetBool, NAME, handler, threads=2)
    try:
        assert (NAME, ["std_srvs/srv/SetBool"]) in server.node.get_service_names_and_types()
        assert NAME not in [s.srv_name for s in server.node.services]  # the executor never sees it
        for data in (True, False, True):
            answer = client.call(SetBool, NAME, SetBool.Request(data=data))
            assert answer.success is data and answer.message == f"service {NAME}"
    finally:
        service.close()
    # a client's own endpoints keep the name in the graph's list; what a client sees is no server
    assert wait_until(lambda: not client.client(SetBool, NAME).service_is_ready(), 10.0), \
        "the service was still offered after close()"
    assert not any(thread.is_alive() for thread in service._threads)


def test_as_many_requests_run_at_once_as_the_service_has_threads(pair):
    server, client = pair
    both_inside = threading.Barrier(2, timeout=10.0)

    def handler(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        try:
            both_inside.wait()  # passes only when the other request is in the handler too
            response.success = True
        except threading.BrokenBarrierError:
            response.success = False
        return response

    service = DedicatedService(server.node, SetBool, NAME, handler, threads=2)
    try:
        futures = [_call_async(client, True) for _ in range(2)]
        assert wait_until(lambda: all(f.done() for f in futures), 20.0)
        assert [f.result().success for f in futures] == [True, True]
    finally:
        service.close()


def test_the_node_executor_goes_on_while_a_request_is_handled(pair):
    server, client = pair
    release = threading.Event()
    received = server.collect(String, "/dedicated_test/topic")

    def handler(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        response.success = release.wait(20.0)
        return response

    service = DedicatedService(server.node, SetBool, NAME, handler, threads=1)
    publisher = client.node.create_publisher(String, "/dedicated_test/topic", 10)
    try:
        future = _call_async(client, True)
        # the request is being handled (and holds the service's only thread) while the node's
        # single-threaded executor still delivers messages
        assert wait_until(lambda: publisher.get_subscription_count() > 0, 10.0)
        for _ in range(50):
            publisher.publish(String(data="tick"))
            if wait_until(lambda: len(received) > 0, 0.2):
                break
        assert received, "the executor did not deliver a message while a request was handled"
        assert not future.done()
        release.set()
        assert wait_until(future.done, 10.0) and future.result().success
    finally:
        release.set()
        service.close()


def test_a_handler_that_raises_answers_a_default_response_and_the_service_goes_on(pair):
    server, client = pair

    def handler(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        if request.data:
            raise RuntimeError("boom")
        response.message = "fine"
        return response

    service = DedicatedService(server.node, SetBool, NAME, handler, threads=1)
    try:
        failed = client.call(SetBool, NAME, SetBool.Request(data=True))
        assert not failed.success and failed.message == ""
        assert client.call(SetBool, NAME, SetBool.Request(data=False)).message == "fine"
    finally:
        service.close()


def test_a_service_needs_a_thread(pair):
    server, _ = pair
    with pytest.raises(ValueError, match="at least one thread"):
        DedicatedService(server.node, SetBool, NAME, lambda q, r: r, threads=0)


def test_one_clients_requests_in_turn_land_on_one_thread(pair):
    """The thread that answered takes the waiting back (leader and followers), so requests that
    come one after another run on one thread, however many the service has."""
    server, client = pair
    idents: list[int] = []

    def handler(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        idents.append(threading.get_ident())
        response.success = True
        return response

    service = DedicatedService(server.node, SetBool, NAME, handler, threads=4)
    try:
        for _ in range(10):
            assert client.call(SetBool, NAME, SetBool.Request(data=True)).success
            time.sleep(0.05)  # the answering thread takes the lead back meanwhile
        _, most = Counter(idents).most_common(1)[0]
        assert most >= 9, f"10 requests in turn ran on {len(set(idents))} threads: {Counter(idents)}"
    finally:
        service.close()
    assert not any(thread.is_alive() for thread in service._threads)


def test_work_after_the_response_runs_once_the_client_has_its_answer(pair):
    """after_response: what the handler leaves for later runs after the response is sent (a
    client never waits for it); outside a handler nothing is taken."""
    server, client = pair
    release, ran = threading.Event(), threading.Event()
    taken: list[bool] = []

    def later() -> None:
        release.wait(20.0)  # had it run before the response, the client would wait for this
        ran.set()

    def handler(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        taken.append(after_response(later))
        response.success = True
        return response

    assert after_response(later) is False  # not in a handler: the caller runs it itself
    service = DedicatedService(server.node, SetBool, NAME, handler, threads=1)
    try:
        future = _call_async(client, True)
        assert wait_until(future.done, 10.0) and future.result().success
        assert taken == [True] and not ran.is_set()
        release.set()
        assert ran.wait(10.0)
        assert client.call(SetBool, NAME, SetBool.Request(data=True)).success  # the thread goes on
    finally:
        release.set()
        service.close()

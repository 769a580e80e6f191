// A client of the Foxglove WebSocket protocol (subprotocol foxglove.websocket.v1; public
// specification: foxglove/ws-protocol, docs/spec.md): what the dashboard speaks to urs-gateway,
// exactly as Foxglove and Lichtblick do. No library; the browser's WebSocket only.
"use strict";

class FoxgloveClient {
  constructor(url) {
    this.url = url;
    this.channels = new Map();       // id -> channel
    this.byTopic = new Map();        // topic -> channel
    this.services = new Map();       // name -> service
    this.servicesById = new Map();
    this.subscriptions = new Map();  // subscription id -> {topic, handler}
    this.wanted = new Map();         // topic -> handler (subscribed again when the channel appears)
    this.calls = new Map();          // call id -> {resolve, reject}
    this.nextSubscription = 1;
    this.nextCall = 1;
    this.serverInfo = null;
    this.onopen = () => {};
    this.onclose = () => {};
    this.onstatus = () => {};
    this.onservices = () => {};
    this.onchannels = () => {};
    this.ongraph = null;
    this.decoder = new TextDecoder();
    this.encoder = new TextEncoder();
  }

  connect() {
    this.ws = new WebSocket(this.url, ["foxglove.websocket.v1"]);
    this.ws.binaryType = "arraybuffer";
    this.ws.onmessage = (event) => this.receive(event.data);
    this.ws.onclose = (event) => {
      for (const call of this.calls.values()) call.reject(new Error("connection closed"));
      this.calls.clear();
      this.onclose(event);
    };
    this.ws.onerror = () => {};
  }

  close() {
    if (this.ws) this.ws.close();
  }

  send(message) {
    if (this.ws && this.ws.readyState === WebSocket.OPEN) this.ws.send(JSON.stringify(message));
  }

  // Calls handler(payload, stampNs) for every message on `topic`, now or once it is advertised.
  subscribe(topic, handler) {
    this.wanted.set(topic, handler);
    const channel = this.byTopic.get(topic);
    if (channel) this.subscribeChannel(channel, handler);
  }

  subscribeChannel(channel, handler) {
    for (const sub of this.subscriptions.values()) if (sub.channel === channel.id) return;
    const id = this.nextSubscription++;
    this.subscriptions.set(id, { channel: channel.id, topic: channel.topic, handler });
    this.send({ op: "subscribe", subscriptions: [{ id, channelId: channel.id }] });
  }

  unsubscribe(topic) {
    this.wanted.delete(topic);
    for (const [id, sub] of this.subscriptions) {
      if (sub.topic === topic) {
        this.subscriptions.delete(id);
        this.send({ op: "unsubscribe", subscriptionIds: [id] });
      }
    }
  }

  subscribeGraph(handler) {
    this.ongraph = handler;
    this.send({ op: "subscribeConnectionGraph" });
  }

  // Calls the service `name` with a JSON request; resolves with the JSON reply, rejects with
  // Error(message) on serviceCallFailure.
  call(name, request) {
    const service = this.services.get(name);
    if (!service) return Promise.reject(new Error("no service " + name));
    const callId = this.nextCall++;
    const encoding = this.encoder.encode("json");
    const payload = this.encoder.encode(JSON.stringify(request));
    const frame = new Uint8Array(13 + encoding.length + payload.length);
    const view = new DataView(frame.buffer);
    view.setUint8(0, 0x02);
    view.setUint32(1, service.id, true);
    view.setUint32(5, callId, true);
    view.setUint32(9, encoding.length, true);
    frame.set(encoding, 13);
    frame.set(payload, 13 + encoding.length);
    return new Promise((resolve, reject) => {
      this.calls.set(callId, { resolve, reject });
      this.ws.send(frame);
    });
  }

  receive(data) {
    if (typeof data === "string") {
      this.receiveJson(JSON.parse(data));
      return;
    }
    const view = new DataView(data);
    const op = view.getUint8(0);
    if (op === 0x01) {
      const id = view.getUint32(1, true);
      const stamp = view.getBigUint64(5, true);
      const sub = this.subscriptions.get(id);
      if (!sub) return;  // unsubscribed: what was in flight
      sub.handler(JSON.parse(this.decoder.decode(new Uint8Array(data, 13))), stamp);
    } else if (op === 0x03) {
      const callId = view.getUint32(5, true);
      const length = view.getUint32(9, true);
      const call = this.calls.get(callId);
      if (!call) return;
      this.calls.delete(callId);
      call.resolve(JSON.parse(this.decoder.decode(new Uint8Array(data, 13 + length))));
    }
  }

  receiveJson(message) {
    switch (message.op) {
      case "serverInfo":
        this.serverInfo = message;
        this.onopen(message);
        break;
      case "status":
        this.onstatus(message);
        break;
      case "advertise":
        for (const channel of message.channels) {
          this.channels.set(channel.id, channel);
          this.byTopic.set(channel.topic, channel);
          const handler = this.wanted.get(channel.topic);
          if (handler) this.subscribeChannel(channel, handler);
        }
        this.onchannels();
        break;
      case "unadvertise":
        for (const id of message.channelIds) {
          const channel = this.channels.get(id);
          this.channels.delete(id);
          if (channel && this.byTopic.get(channel.topic) === channel) this.byTopic.delete(channel.topic);
          for (const [sub, entry] of this.subscriptions) if (entry.channel === id) this.subscriptions.delete(sub);
        }
        this.onchannels();
        break;
      case "advertiseServices":
        for (const service of message.services) {
          this.services.set(service.name, service);
          this.servicesById.set(service.id, service);
        }
        this.onservices();
        break;
      case "unadvertiseServices":
        for (const id of message.serviceIds) {
          const service = this.servicesById.get(id);
          this.servicesById.delete(id);
          if (service && this.services.get(service.name) === service) this.services.delete(service.name);
        }
        this.onservices();
        break;
      case "serviceCallFailure": {
        const call = this.calls.get(message.callId);
        if (call) {
          this.calls.delete(message.callId);
          call.reject(new Error(message.message));
        }
        break;
      }
      case "connectionGraphUpdate":
        if (this.ongraph) this.ongraph(message);
        break;
      default:
        break;
    }
  }
}

// Third-party VDA 5050 2.0 vehicles for the tests: the npm package vda-5050-lib (pinned in
// package.json), its AgvController driving its VirtualAgvAdapter, one per entry of the JSON
// file named on the command line:
//
//   {"broker": "mqtt://127.0.0.1:1883", "interface": "hdtest...", "timeLapse": 10,
//    "vehicles": [{"manufacturer": "Acme", "serialNumber": "SN-1", "publishStateInterval": 30000,
//                  "position": {"x": 0, "y": 0, "theta": 0, "mapId": "1F", "lastNodeId": "D"}}]}
//
// Nothing here is ours but the wiring: the vehicles do what the library does. Prints one line
// "ready" once every vehicle is connected; stops on SIGTERM, publishing OFFLINE as the library
// does on an orderly stop.
"use strict";

const fs = require("fs");
const { AgvController, VirtualAgvAdapter } = require("vda-5050-lib");

async function main() {
    const config = JSON.parse(fs.readFileSync(process.argv[2], "utf8"));
    const controllers = config.vehicles.map(vehicle => new AgvController(
        { manufacturer: vehicle.manufacturer, serialNumber: vehicle.serialNumber },
        {
            interfaceName: config.interface,
            transport: { brokerUrl: config.broker },
            vdaVersion: "2.0.0",
        },
        {
            agvAdapterType: VirtualAgvAdapter,
            publishStateInterval: vehicle.publishStateInterval,
            publishVisualizationInterval: 0,
        },
        {
            initialPosition: vehicle.position,
            timeLapse: config.timeLapse,
        },
    ));
    for (const controller of controllers) {
        await controller.start();
    }
    process.stdout.write("ready\n");
    const stop = async () => {
        for (const controller of controllers) {
            await controller.stop();
        }
        process.exit(0);
    };
    process.on("SIGTERM", stop);
    process.on("SIGINT", stop);
}

main().catch(error => {
    process.stderr.write(`${error.stack || error}\n`);
    process.exit(1);
});

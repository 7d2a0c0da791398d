// A mission with drones but nothing to do.
package NothingToDo

var Drone1 Quadcopter

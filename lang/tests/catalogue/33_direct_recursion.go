// A block that runs itself.
package SelfCall

var Drone1 Quadcopter

func INIT() {
	SEQ_Loop()
}

func SEQ_Loop() {
	Drone1.FlyByX(1)
	SEQ_Loop()
}
